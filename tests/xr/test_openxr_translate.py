"""The real OpenXR port's translation, with pyopenxr's own structs and enums.

No runtime exists here, so the runtime's answers come from a script, but
they are the real ``xr`` types (``EventDataBuffer``, ``SpaceLocation``,
``View``, ``FrameState``, ``ActionStateVector2f`` ...) that pyopenxr hands
back on a headset: what :class:`~pedvr.xr.openxr.OpenXRPort` reads from them
(events through the ctypes cast, poses with the floor offset, the per-eye
fov, validity flags, button edges, the frame it submits) is checked for
real. The decisions on top are tested with a fake port in ``test_session``.
"""

from __future__ import annotations

import ctypes
from typing import Any

import numpy as np
import pytest

xr = pytest.importorskip("xr")

from pedvr.xr.openxr import OpenXRPort  # noqa: E402
from pedvr.xr.session import InstanceLossPending, SessionState, StateChanged  # noqa: E402

NS = 1_000_000_000


def _event(struct: Any) -> Any:
    """An ``EventDataBuffer`` holding ``struct``, as ``xrPollEvent`` fills it."""
    buf = xr.EventDataBuffer()
    ctypes.memmove(ctypes.byref(buf), ctypes.byref(struct), ctypes.sizeof(struct))
    return buf


def _handle(kind: Any, value: int) -> Any:
    """A real pyopenxr handle of type ``kind`` with a distinct (fake) address."""
    return ctypes.cast(ctypes.c_void_p(value), kind)


def _addr(handle: Any) -> int:
    return int(ctypes.cast(handle, ctypes.c_void_p).value or 0)


ACTIONS = {name: k for k, name in enumerate(("move", "turn", "trigger", "menu", "grip"), start=0x100)}
NAMES = {v: k for k, v in ACTIONS.items()}


def _posef(p: tuple[float, float, float], q: tuple[float, float, float, float]) -> Any:
    return xr.Posef(orientation=xr.Quaternionf(*q), position=xr.Vector3f(*p))


class ScriptedRuntime:
    """The real ``xr`` module's types, enums and errors; the runtime's calls answered from a script."""

    def __init__(self) -> None:
        self.events: list[Any] = []
        self.head = xr.SpaceLocation()
        self.view_state = xr.ViewState()
        self.views: list[Any] = []
        self.frame_state = xr.FrameState()
        self.vectors: dict[tuple[str, int], Any] = {}
        self.booleans: dict[str, list[Any]] = {}
        self.hand_booleans: dict[tuple[str, int], Any] = {}  # per-hand states (a subaction path given)
        self.spaces: dict[int, Any] = {}  # located spaces other than the head, by handle address
        self.calls: list[tuple[str, object]] = []
        self.released = 0

    def __getattr__(self, name: str) -> Any:
        return getattr(xr, name)

    def poll_event(self, instance: object) -> Any:
        if not self.events:
            raise xr.EventUnavailable()
        return self.events.pop(0)

    def wait_frame(self, session: object, info: object) -> Any:
        return self.frame_state

    def locate_space(self, space: object, base: object, time: int) -> Any:
        self.calls.append(("locate_space", time))
        return self.spaces.get(_addr(space), self.head)

    def locate_views(self, session: object, info: Any) -> tuple[Any, list[Any]]:
        self.calls.append(("locate_views", info.display_time))
        return self.view_state, self.views

    def sync_actions(self, session: object, info: object) -> None:
        self.calls.append(("sync_actions", None))

    def get_action_state_vector2f(self, session: object, info: Any) -> Any:
        return self.vectors[(NAMES[_addr(info.action)], info.subaction_path)]

    def get_action_state_boolean(self, session: object, info: Any) -> Any:
        if info.subaction_path != xr.NULL_PATH:
            return self.hand_booleans.get((NAMES[_addr(info.action)], info.subaction_path),
                                          xr.ActionStateBoolean())
        return self.booleans[NAMES[_addr(info.action)]].pop(0)

    def acquire_swapchain_image(self, swapchain: object, info: object) -> int:
        return 1

    def wait_swapchain_image(self, swapchain: object, info: object) -> None:
        pass

    def release_swapchain_image(self, swapchain: object, info: object) -> None:
        self.released += 1

    def end_frame(self, session: object, info: Any) -> None:
        self.calls.append(("end_frame", info))


@pytest.fixture
def port() -> tuple[OpenXRPort, ScriptedRuntime]:
    p = OpenXRPort()  # imports the real pyopenxr; starts nothing
    rt = ScriptedRuntime()
    p.xr = rt
    p.instance, p.session = _handle(xr.Instance, 0x10), _handle(xr.Session, 0x20)
    p.space, p.view_space = _handle(xr.Space, 0x30), _handle(xr.Space, 0x40)
    p._actions = {name: _handle(xr.Action, k) for name, k in ACTIONS.items()}
    p._hands = [1, 2]  # XrPath values of /user/hand/left and /user/hand/right
    p._action_set = _handle(xr.ActionSet, 0x50)
    return p, rt


def test_events_come_through_the_buffer_cast(port: tuple[OpenXRPort, ScriptedRuntime]) -> None:
    p, rt = port
    rt.events = [
        _event(xr.EventDataSessionStateChanged(state=xr.SessionState.READY)),
        _event(xr.EventDataSessionStateChanged(state=xr.SessionState.LOSS_PENDING)),
        _event(xr.EventDataInstanceLossPending()),
    ]
    got = p.poll_events()
    assert got == [StateChanged(SessionState.READY), StateChanged(SessionState.LOSS_PENDING),
                   InstanceLossPending()]
    assert p.poll_events() == []


def test_the_predicted_time_is_kept_in_nanoseconds_and_drives_locating(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port
    rt.frame_state = xr.FrameState(predicted_display_time=5 * NS + 123, predicted_display_period=11_111_111,
                                   should_render=True)
    frame = p.wait_frame()
    assert frame.display_time == pytest.approx(5.000000123) and frame.period == pytest.approx(0.011111111)
    assert frame.should_render is True
    p.locate_head(frame.display_time)
    p.locate_views(frame.display_time)
    # The runtime is asked at its own integer time, not a float round trip.
    assert rt.calls == [("locate_space", 5 * NS + 123), ("locate_views", 5 * NS + 123)]


def test_head_pose_needs_both_valid_bits_and_gets_the_floor_offset(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port
    q = (0.0, 0.3826834, 0.0, 0.9238795)  # 45 degrees about +Y
    rt.head = xr.SpaceLocation(location_flags=xr.SpaceLocationFlags.POSITION_VALID_BIT,
                               pose=_posef((0.5, 0.1, -1.0), q))
    assert p.locate_head(0.0) is None  # orientation not valid: tracking lost
    rt.head.location_flags = (xr.SpaceLocationFlags.POSITION_VALID_BIT
                              | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT)
    p._height_offset = 1.65  # a LOCAL space (head height) raised to standing eyes
    pose = p.locate_head(0.0)
    assert pose is not None
    np.testing.assert_allclose(pose.position, [0.5, 1.75, -1.0], atol=1e-6)
    np.testing.assert_allclose(pose.orientation, q, atol=1e-6)


def _view(p: tuple[float, float, float], fov: tuple[float, float, float, float]) -> Any:
    return xr.View(pose=_posef(p, (0.0, 0.0, 0.0, 1.0)), fov=xr.Fovf(*fov))


def test_views_carry_each_eyes_own_fov_in_left_right_up_down_order(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port
    left = (-0.9, 0.7, 0.8, -0.85)
    right = (-0.7, 0.9, 0.8, -0.85)
    rt.views = [_view((-0.032, 1.6, 0.0), left), _view((0.032, 1.6, 0.0), right)]
    assert p.locate_views(0.0) == []  # view state not valid yet
    rt.view_state = xr.ViewState(view_state_flags=xr.ViewStateFlags.POSITION_VALID_BIT
                                 | xr.ViewStateFlags.ORIENTATION_VALID_BIT)
    views = p.locate_views(0.0)
    assert len(views) == 2
    for v, fov, x in zip(views, (left, right), (-0.032, 0.032), strict=True):
        np.testing.assert_allclose(v.fov, fov, atol=1e-6)
        np.testing.assert_allclose(v.pose.position, [x, 1.6, 0.0], atol=1e-6)


def test_controls_read_left_move_right_turn_and_button_edges(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port

    def vec(x: float, y: float, active: bool = True) -> Any:
        return xr.ActionStateVector2f(current_state=xr.Vector2f(x, y), is_active=active)

    def button(on: bool) -> Any:
        return xr.ActionStateBoolean(current_state=on, is_active=True)

    assert p.sync_controls(focused=False).move == (0.0, 0.0)
    assert rt.calls == []  # not focused: the runtime is not even asked
    rt.vectors = {("move", 1): vec(0.25, 0.75), ("turn", 2): vec(-0.9, 0.1)}
    rt.booleans = {"trigger": [button(True), button(True), button(False), button(True)],
                   "menu": [button(False)] * 4}
    c = p.sync_controls(focused=True)
    assert c.move == pytest.approx((0.25, 0.75)) and c.turn == pytest.approx(-0.9)
    presses = [c.trigger] + [p.sync_controls(focused=True).trigger for _ in range(3)]
    assert presses == [True, False, False, True]  # a press is its rising edge, once
    rt.vectors[("move", 1)] = vec(1.0, 1.0, active=False)  # an inactive action reads as centred
    rt.booleans = {"trigger": [button(False)], "menu": [button(False)]}
    assert p.sync_controls(focused=True).move == (0.0, 0.0)


def test_render_eye_releases_the_image_even_when_drawing_fails(port: tuple[OpenXRPort, ScriptedRuntime]) -> None:
    p, rt = port
    p.swapchains = ["sc0", "sc1"]
    p.targets = [[(None, None, "fbo0.0"), (None, None, "fbo0.1")], [(None, None, "fbo1.0"), (None, None, "fbo1.1")]]
    p.sizes = [(1832, 1920), (1832, 1920)]
    drawn: list[tuple[object, tuple[int, int, int, int]]] = []
    p.render_eye(1, lambda fbo, vp: drawn.append((fbo, vp)))
    assert drawn == [("fbo1.1", (0, 0, 1832, 1920))]  # the acquired image's framebuffer
    with pytest.raises(RuntimeError):
        p.render_eye(0, lambda fbo, vp: (_ for _ in ()).throw(RuntimeError("shader")))
    assert rt.released == 2


def test_end_frame_submits_the_located_views_at_the_predicted_time(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port
    p.swapchains = [_handle(xr.Swapchain, 0x60), _handle(xr.Swapchain, 0x70)]
    p.sizes = [(1600, 1700), (1600, 1700)]
    rt.frame_state = xr.FrameState(predicted_display_time=7 * NS, predicted_display_period=1, should_render=True)
    rt.view_state = xr.ViewState(view_state_flags=xr.ViewStateFlags.POSITION_VALID_BIT
                                 | xr.ViewStateFlags.ORIENTATION_VALID_BIT)
    rt.views = [_view((-0.03, 1.6, 0.0), (-0.9, 0.7, 0.8, -0.85)), _view((0.03, 1.6, 0.0), (-0.7, 0.9, 0.8, -0.85))]
    frame = p.wait_frame()
    views = p.locate_views(frame.display_time)
    p.end_frame(display_time=frame.display_time, views=views)
    (_, info), = [c for c in rt.calls if c[0] == "end_frame"]
    assert info.display_time == 7 * NS
    assert info.environment_blend_mode == xr.EnvironmentBlendMode.OPAQUE
    assert info.layer_count == 1
    layer = p._layer
    assert layer.view_count == 2
    for k in range(2):
        pv = layer.views[k]
        assert pv.fov.angle_left == pytest.approx(rt.views[k].fov.angle_left)
        assert pv.pose.position.x == pytest.approx(rt.views[k].pose.position.x)
        assert (pv.sub_image.image_rect.extent.width, pv.sub_image.image_rect.extent.height) == (1600, 1700)
        assert _addr(pv.sub_image.swapchain) == _addr(p.swapchains[k])  # each eye its own swapchain
    p.end_frame(display_time=frame.display_time, views=None)  # nothing to show: an empty frame
    assert [c for c in rt.calls if c[0] == "end_frame"][-1][1].layer_count == 0


VALID = xr.SpaceLocationFlags.POSITION_VALID_BIT | xr.SpaceLocationFlags.ORIENTATION_VALID_BIT


def test_grip_poses_are_located_per_hand_in_the_reference_space_and_need_both_valid_bits(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    p, rt = port
    p._grip_spaces = [_handle(xr.Space, 0x80), _handle(xr.Space, 0x90)]
    rt.frame_state = xr.FrameState(predicted_display_time=3 * NS + 7, predicted_display_period=1, should_render=True)
    p.wait_frame()
    q = (0.0, 0.0, 0.0, 1.0)
    rt.spaces = {0x80: xr.SpaceLocation(location_flags=xr.SpaceLocationFlags.POSITION_VALID_BIT,
                                        pose=_posef((-0.2, 0.9, -0.3), q)),
                 0x90: xr.SpaceLocation(location_flags=VALID, pose=_posef((0.25, 1.0, -0.4), q))}
    p._height_offset = 1.65  # a LOCAL space: the hands are raised with the head
    left, right = p.locate_hands(0.0)
    assert left is None  # position without orientation: not tracked
    assert right is not None
    np.testing.assert_allclose(right.position, [0.25, 2.65, -0.4], atol=1e-6)
    assert rt.calls == [("locate_space", 3 * NS + 7)] * 2  # at the runtime's own predicted time
    rt.spaces[0x80].location_flags = VALID
    rt.spaces[0x90].location_flags = 0  # a controller switched off
    left, right = p.locate_hands(0.0)
    assert right is None and left is not None
    np.testing.assert_allclose(left.position, [-0.2, 2.55, -0.3], atol=1e-6)


def test_the_trigger_says_which_hand_pressed_it(port: tuple[OpenXRPort, ScriptedRuntime]) -> None:
    p, rt = port
    rt.vectors = {("move", 1): xr.ActionStateVector2f(), ("turn", 2): xr.ActionStateVector2f()}
    down = xr.ActionStateBoolean(current_state=True, is_active=True)
    up = xr.ActionStateBoolean(current_state=False, is_active=True)
    rt.booleans = {"trigger": [down, down, up, down], "menu": [up] * 4}
    rt.hand_booleans = {("trigger", 1): down}  # the left hand (path 1) holds it
    c = p.sync_controls(focused=True)
    assert c.trigger and c.trigger_hand == 0
    assert p.sync_controls(focused=True).trigger_hand == -1  # held, not pressed again: no hand asked
    p.sync_controls(focused=True)
    rt.hand_booleans = {("trigger", 1): down, ("trigger", 2): down}  # both: the right one
    assert p.sync_controls(focused=True).trigger_hand == 1


class SetupRuntime(ScriptedRuntime):
    """Answers the start-up calls of the action set: records actions, bindings and action spaces."""

    def __init__(self) -> None:
        super().__init__()
        self.paths: dict[str, int] = {}
        self.created: dict[str, Any] = {}
        self.bindings: dict[str, list[tuple[str, str]]] = {}
        self.action_spaces: list[tuple[str, int, Any]] = []

    def string_to_path(self, instance: object, s: str) -> int:
        return self.paths.setdefault(s, len(self.paths) + 1)

    def create_action_set(self, instance: object, info: object) -> Any:
        return _handle(xr.ActionSet, 0x50)

    def create_action(self, action_set: object, info: Any) -> Any:
        name = info.action_name.decode() if isinstance(info.action_name, bytes) else str(info.action_name)
        self.created[name] = info
        return _handle(xr.Action, ACTIONS[name])

    def suggest_interaction_profile_bindings(self, instance: object, info: Any) -> None:
        where = {v: k for k, v in self.paths.items()}
        self.bindings[where[info.interaction_profile]] = [
            (NAMES[_addr(b.action)], where[b.binding])
            for b in (info.suggested_bindings[k] for k in range(info.count_suggested_bindings))
        ]

    def attach_session_action_sets(self, session: object, info: object) -> None:
        pass

    def create_action_space(self, session: object, info: Any) -> Any:
        self.action_spaces.append((NAMES[_addr(info.action)], int(info.subaction_path), info.pose_in_action_space))
        return _handle(xr.Space, 0x80 + 0x10 * len(self.action_spaces))


def test_the_action_set_has_a_grip_pose_per_hand_bound_for_every_profile_with_an_action_space_each() -> None:
    p = OpenXRPort()
    rt = SetupRuntime()
    p.xr = rt
    p.instance, p.session = _handle(xr.Instance, 0x10), _handle(xr.Session, 0x20)
    p._actions_setup()
    grip = rt.created["grip"]
    assert grip.action_type == xr.ActionType.POSE_INPUT
    hands = [rt.paths["/user/hand/left"], rt.paths["/user/hand/right"]]
    assert [grip.subaction_paths[k] for k in range(grip.count_subaction_paths)] == hands
    assert len(rt.bindings) == 5  # every profile bound, each with both grip poses
    for profile, pairs in rt.bindings.items():
        assert ("grip", "/user/hand/left/input/grip/pose") in pairs, profile
        assert ("grip", "/user/hand/right/input/grip/pose") in pairs, profile
    assert [(a, h) for a, h, _ in rt.action_spaces] == [("grip", hands[0]), ("grip", hands[1])]
    for *_, pose in rt.action_spaces:  # the grip itself, no offset
        assert (pose.position.x, pose.position.y, pose.position.z, pose.orientation.w) == (0.0, 0.0, 0.0, 1.0)
    assert [_addr(s) for s in p._grip_spaces] == [0x90, 0xA0]


def test_the_frame_period_is_the_displays_refresh_where_the_runtime_says(
    port: tuple[OpenXRPort, ScriptedRuntime],
) -> None:
    """Issue 23 item 6: Monado's predicted period follows a slow application's pace (up to 683 ms),
    so misses counted against it vanish; XR_FB_display_refresh_rate gives the display's own."""
    p, rt = port
    rt.frame_state = xr.FrameState(predicted_display_time=NS, predicted_display_period=683_000_000,
                                   should_render=True)
    assert p.wait_frame().period == pytest.approx(0.683)  # no refresh rate known: the predicted one
    p.refresh_hz = 90.0
    assert p.wait_frame().period == pytest.approx(1 / 90)


@pytest.mark.parametrize("error", ["SessionLostError", "InstanceLostError", "RuntimeFailureError"])
def test_a_lost_runtime_inside_a_frame_call_is_one_line(
    port: tuple[OpenXRPort, ScriptedRuntime], error: str,
) -> None:
    from pedvr.xr.session import RuntimeLostError

    p, rt = port

    def lost(session: object, info: object) -> None:
        raise getattr(xr, error)()

    rt.begin_frame = lost  # type: ignore[attr-defined]
    with pytest.raises(RuntimeLostError, match=r"^the OpenXR runtime went away \(\w+ in begin_frame\): "
                                               r"restart it") as exc:
        p.begin_frame()
    assert "\n" not in str(exc.value)
