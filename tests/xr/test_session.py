"""The OpenXR backend's logic through a fake session: states, frames, poses, controls, loss."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pytest

from pedvr.render.math3d import (
    EyeView,
    first_person_rotation,
    matrix_to_quat,
    projection_from_fov,
    quat_to_matrix,
    rot_y,
)
from pedvr.xr.locomotion import Controls, HeadsetUser
from pedvr.xr.session import (
    InstanceLossPending,
    Pose,
    SessionState,
    StateChanged,
    ViewLocation,
    XrFrame,
    XrPresenter,
)

FOV = (-0.8, 0.75, 0.7, -0.72)


def head_pose(x: float, z: float, yaw: float = 0.0, height: float = 1.7) -> Pose:
    """A head at tracking (x, height, z) turned by ``yaw`` about +Y (OpenXR: looking down -Z at yaw 0)."""
    q = matrix_to_quat(rot_y(yaw))
    return Pose(position=np.array([x, height, z]), orientation=q)


@dataclass
class FakePort:
    """Scripted events per frame; records what the presenter asked of the runtime."""

    events: list[list[object]] = field(default_factory=list)
    head: Pose | None = field(default_factory=lambda: head_pose(0.0, 0.0))
    controls: list[Controls] = field(default_factory=list)
    should_render: bool = True
    period: float = 1 / 90
    calls: list[str] = field(default_factory=list)
    frame_index: int = 0
    rendered: list[int] = field(default_factory=list)
    ended: list[int | None] = field(default_factory=list)
    hands: list[Pose | None] = field(default_factory=lambda: [None, None])

    def poll_events(self) -> list[object]:
        return list(self.events.pop(0)) if self.events else []

    def begin_session(self) -> None:
        self.calls.append("begin")

    def end_session(self) -> None:
        self.calls.append("end")

    def request_exit(self) -> None:
        self.calls.append("request_exit")

    def wait_frame(self) -> XrFrame:
        self.frame_index += 1
        return XrFrame(
            display_time=100.0 + self.frame_index * self.period,
            period=self.period,
            should_render=self.should_render,
        )

    def begin_frame(self) -> None:
        self.calls.append("begin_frame")

    def locate_head(self, display_time: float) -> Pose | None:
        return self.head

    def locate_views(self, display_time: float) -> list[ViewLocation]:
        if self.head is None:
            return []
        # Each eye half the IPD along the head's own right axis (+X of the head's orientation).
        p, r = self.head.position, quat_to_matrix(*self.head.orientation)
        return [
            ViewLocation(pose=Pose(position=p + r @ [dx, 0, 0], orientation=self.head.orientation), fov=FOV)
            for dx in (-0.032, 0.032)
        ]

    def sync_controls(self, *, focused: bool) -> Controls:
        if not focused or not self.controls:
            return Controls()
        return self.controls.pop(0)

    def locate_hands(self, display_time: float) -> list[Pose | None]:
        return list(self.hands)

    def render_eye(self, index: int, draw: Callable[[object, tuple[int, int, int, int]], None]) -> None:
        draw("fbo", (0, 0, 10, 10))
        self.rendered.append(index)

    def end_frame(self, *, display_time: float, views: list[ViewLocation] | None) -> None:
        self.ended.append(None if views is None else len(views))

    def idle_wait(self) -> None:
        self.calls.append("idle")

    def runtime_facts(self) -> dict[str, object]:
        return {"runtime": "FakePort", "interaction_profiles": {"left": None, "right": None}}

    def close(self) -> None:
        self.calls.append("close")


def presenter(port: FakePort, **kw: object) -> tuple[XrPresenter, list[EyeView]]:
    drawn: list[EyeView] = []
    user = HeadsetUser(start=(2.0, 3.0), heading=0.0, **kw)  # type: ignore[arg-type]
    return XrPresenter(port, user=user, draw_eye=lambda eye, fbo, vp: drawn.append(eye)), drawn


def frame(p: XrPresenter) -> bool:
    timing = p.wait_frame()
    if timing is None:
        return False
    if timing.should_render:
        p.render(sim=None)  # type: ignore[arg-type]
    p.end_frame()
    return True


READY = [StateChanged(SessionState.READY)]
FOCUS = [
    StateChanged(SessionState.SYNCHRONIZED),
    StateChanged(SessionState.VISIBLE),
    StateChanged(SessionState.FOCUSED),
]


def test_no_frames_before_ready_then_begin_on_ready_and_render_both_eyes() -> None:
    port = FakePort(events=[[StateChanged(SessionState.IDLE)], READY + FOCUS])
    p, drawn = presenter(port)
    assert frame(p) is False and port.calls == ["idle"]
    assert frame(p) is True
    assert port.calls[1:3] == ["begin", "begin_frame"]
    assert port.rendered == [0, 1] and port.ended == [2] and len(drawn) == 2


def test_should_render_false_submits_an_empty_frame() -> None:
    port = FakePort(events=[READY], should_render=False)
    p, drawn = presenter(port)
    assert frame(p)
    assert port.rendered == [] and port.ended == [None] and drawn == []


def test_stopping_ends_the_session_and_exiting_closes() -> None:
    port = FakePort(
        events=[
            READY + FOCUS,
            [StateChanged(SessionState.STOPPING)],
            [StateChanged(SessionState.IDLE), StateChanged(SessionState.EXITING)],
        ]
    )
    p, _ = presenter(port)
    assert frame(p)
    assert not frame(p) and "end" in port.calls and not p.closed
    frame(p)
    assert p.closed and p.lost is None
    assert p.logic.history[-1] == SessionState.EXITING


@pytest.mark.parametrize(
    "event, words",
    [
        (StateChanged(SessionState.LOSS_PENDING), "headset was lost"),
        (InstanceLossPending(), "instance loss pending"),
    ],
)
def test_loss_pending_ends_the_session_and_says_why_in_one_line(event: object, words: str) -> None:
    port = FakePort(events=[READY + FOCUS, [event]])
    p, _ = presenter(port)
    assert frame(p)
    frame(p)
    assert p.closed and p.lost is not None and words in p.lost and "\n" not in p.lost
    assert port.calls.count("end") == 1


def test_request_exit_asks_the_runtime_once() -> None:
    port = FakePort(events=[READY])
    p, _ = presenter(port)
    frame(p)
    p.request_exit()
    p.request_exit()
    assert port.calls.count("request_exit") == 1


@pytest.mark.parametrize("heading", [0.0, 0.7, math.pi / 2, -2.5])
def test_a_head_at_rest_faces_the_scenes_heading_as_the_headless_view_does(heading: float) -> None:
    # Issue 23 item 1: the play space's yaw was off by π/2 (the participant started facing a wall).
    port = FakePort(events=[READY + FOCUS], head=head_pose(0.0, 0.0))
    drawn: list[EyeView] = []
    user = HeadsetUser(start=(2.0, 3.0), heading=heading)
    p = XrPresenter(port, user=user, draw_eye=lambda eye, fbo, vp: drawn.append(eye))
    frame(p)
    _, h = p.user.pose(1e9)
    assert math.cos(h - heading) == pytest.approx(1.0)
    expected = first_person_rotation(heading)
    for eye in drawn:
        assert np.allclose(eye.view[:3, :3].T, expected, atol=1e-9)  # the view's inverse rotation


def test_head_pose_becomes_the_user_agent_on_the_floor_with_its_yaw() -> None:
    # Tracking (0.5, 1.7, -1.0), turned 90° left (yaw +π/2 about +Y: looking down -X in tracking space).
    port = FakePort(events=[READY + FOCUS], head=head_pose(0.5, -1.0, yaw=math.pi / 2))
    p, _ = presenter(port)
    frame(p)
    pos, heading = p.user.pose(1e9)
    # The play space faces the start heading 0 (world +x) with tracking -Z: tracking (x, z) ->
    # world (2 - z, 3 + x), so 1 m ahead and 0.5 m to the right (2D +y is the right, math3d).
    assert pos == pytest.approx([3.0, 3.5])
    # Turned 90° left of heading 0 is 2D heading -π/2 (turning right makes the heading grow).
    assert math.sin(heading) == pytest.approx(-1.0)


def test_eye_views_use_each_eyes_off_axis_projection_and_the_play_space() -> None:
    port = FakePort(events=[READY + FOCUS], head=head_pose(0.0, 0.0))
    p, drawn = presenter(port)
    frame(p)
    expected = projection_from_fov(angle_left=FOV[0], angle_right=FOV[1], angle_up=FOV[2], angle_down=FOV[3])
    assert np.allclose(drawn[0].projection, expected)
    # Facing world +x, the left eye is on 2D -y (the user's left), the right eye on +y.
    assert drawn[0].position == pytest.approx([2.0, 1.7, 3.0 - 0.032])
    assert drawn[1].position == pytest.approx([2.0, 1.7, 3.0 + 0.032])


def test_thumbstick_moves_the_user_where_the_head_faces_at_walking_speed() -> None:
    # A head at rest faces the start heading (0: world +x).
    port = FakePort(events=[READY + FOCUS], controls=[Controls()] + [Controls(move=(0.0, 1.0))] * 90)
    p, _ = presenter(port)
    for _ in range(91):
        frame(p)
    pos, heading = p.user.pose(1e9)
    assert heading == pytest.approx(0.0)
    assert pos == pytest.approx([2.0 + 1.3, 3.0], abs=1e-6)  # 1 s at 1.3 m/s along 2D +x
    assert p.user.moving_speed == pytest.approx(1.3)


def test_snap_turn_is_30_degrees_about_the_head_and_rearms_only_after_release() -> None:
    port = FakePort(
        events=[READY + FOCUS],
        head=head_pose(0.4, 0.2),
        controls=[
            Controls(),
            Controls(turn=0.9),
            Controls(turn=0.95),
            Controls(turn=0.1),
            Controls(turn=0.9),
        ],
    )
    p, _ = presenter(port)
    frame(p)
    pos0, h0 = p.user.pose(1e9)
    frame(p)
    pos1, h1 = p.user.pose(1e9)
    assert (h1 - h0) == pytest.approx(math.radians(30))  # stick right: turn right (2D heading grows)
    assert pos1 == pytest.approx(pos0)  # turned in place
    frame(p)  # still held: no second turn
    assert p.user.snap_turns == 1
    frame(p)  # released
    frame(p)
    assert p.user.snap_turns == 2


def test_no_input_while_not_focused() -> None:
    port = FakePort(
        events=[READY + [StateChanged(SessionState.VISIBLE)]], controls=[Controls(move=(0, 1))] * 5
    )
    p, _ = presenter(port)
    for _ in range(5):
        frame(p)
    assert p.user.pose(1e9)[0] == pytest.approx([2.0, 3.0])


def test_lost_tracking_keeps_the_last_pose_and_skips_rendering() -> None:
    port = FakePort(events=[READY + FOCUS], head=head_pose(1.0, 0.0))
    p, drawn = presenter(port)
    frame(p)
    port.head = None
    frame(p)
    assert p.user.pose(1e9)[0] == pytest.approx([2.0, 4.0])  # tracking +x: the right, 2D +y (math3d)
    assert port.ended[-1] == 0 and len(drawn) == 2  # second frame: empty layer list, nothing drawn


def test_a_lost_runtime_mid_call_ends_the_loop_with_one_line_not_an_exception() -> None:
    """Issue 23 item 4: XR_ERROR_INSTANCE_LOST escaped from xrBeginFrame as SessionLostError."""
    from pedvr.xr.session import RuntimeLostError

    class Losing(FakePort):
        def begin_frame(self) -> None:
            if self.frame_index >= 3:
                raise RuntimeLostError("the OpenXR runtime went away (InstanceLost in begin_frame): restart it")
            super().begin_frame()

    port = Losing(events=[READY + FOCUS])
    p, _ = presenter(port)
    assert frame(p) and frame(p)
    assert p.wait_frame() is None
    assert p.closed and p.lost is not None and "went away" in p.lost and "\n" not in p.lost
    p.finish()  # nothing to end politely: no exception, no calls to a dead runtime
    assert "request_exit" not in port.calls


def test_finish_ends_a_frame_left_open_with_no_layers_before_asking_to_exit() -> None:
    port = FakePort(events=[READY + FOCUS, [], [StateChanged(SessionState.STOPPING)],
                            [StateChanged(SessionState.IDLE), StateChanged(SessionState.EXITING)]])
    p, _ = presenter(port)
    assert frame(p)
    p.wait_frame()  # ... and an interrupt (Ctrl-C, SIGTERM) lands before this frame is ended
    p.finish(timeout=1.0)
    assert port.ended[:2] == [2, None]  # the open frame ended with no layers, nothing half-drawn
    assert port.calls.index("request_exit") > port.calls.index("begin_frame")
    assert p.closed and p.logic.history[-1] == SessionState.EXITING


def test_a_signal_that_cut_a_runtime_call_short_ends_the_run_as_interrupted() -> None:
    """Against Monado, Ctrl-C during ``xrAcquireSwapchainImage`` made its IPC ``recvmsg`` fail
    (EINTR), the call reported the session lost, and the run exited 3 ("the runtime went away")
    instead of 130: the signal came first."""
    from pedvr.xr.run import lost_first

    assert lost_first(False, "the OpenXR runtime went away (SessionLost in end_frame)")
    assert not lost_first(True, "the OpenXR runtime went away (SessionLost in end_frame)")
    assert not lost_first("SIGTERM", "the OpenXR runtime went away (SessionLost in end_frame)")
    assert not lost_first(False, None)
