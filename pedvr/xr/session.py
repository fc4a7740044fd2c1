"""OpenXR backend logic, independent of pyopenxr: session states, frames, poses, controls.

:class:`XrPresenter` drives an :class:`XrPort` — the thin layer of real
pyopenxr calls in :mod:`pedvr.xr.openxr`, or a fake in tests — through the
OpenXR session life cycle (OpenXR 1.0 §9.3):

* ``READY``: begin the session (stereo view configuration); frames start.
* ``SYNCHRONIZED`` / ``VISIBLE`` / ``FOCUSED``: frames run; input only when focused.
* ``STOPPING``: end the session; frames stop.
* ``EXITING``: the runtime or the user ended it; the loop stops normally.
* ``LOSS_PENDING`` (or instance loss): the headset went away; the loop stops
  and :attr:`XrPresenter.lost` says why (one line, no traceback). A port call
  that finds the session or instance already lost (the runtime killed or
  crashed: ``XR_ERROR_SESSION_LOST``, ``XR_ERROR_INSTANCE_LOST``) raises
  :class:`RuntimeLostError`, which ends the loop the same way.

Each frame: ``wait_frame`` (predicted display time drives the simulation
clock), ``begin_frame``, locate the head and the per-eye views at the
predicted time, feed :class:`~pedvr.xr.locomotion.HeadsetUser` (head pose,
thumbstick, snap turn), render each eye with its own view and off-axis
projection, ``end_frame`` with a projection layer (or none when the runtime
says not to render).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from pedvr.errors import BackendUnavailableError
from pedvr.render.math3d import FAR, NEAR, EyeView, projection_from_fov, quat_to_matrix
from pedvr.xr.locomotion import Controls, HeadsetUser
from pedvr.xr.loop import FrameTiming

if TYPE_CHECKING:
    from pedvr.sim import Simulation


class BackendLostError(BackendUnavailableError):
    """The OpenXR session ended early (headset or runtime lost); the run so far is saved."""


FACTS_AFTER_FRAMES = 10  # focused frames before the runtime's facts are read (controllers bound by then)


class RuntimeLostError(Exception):
    """A port call found the OpenXR session or instance lost (the runtime went away mid-call).

    The message is one line saying what happened and what to do; :class:`XrPresenter` turns it
    into :attr:`XrPresenter.lost` instead of letting it escape the frame loop (issue 23 item 4)."""


class SessionState(enum.IntEnum):
    """``XrSessionState`` values (OpenXR 1.0)."""

    UNKNOWN = 0
    IDLE = 1
    READY = 2
    SYNCHRONIZED = 3
    VISIBLE = 4
    FOCUSED = 5
    STOPPING = 6
    LOSS_PENDING = 7
    EXITING = 8


@dataclass(frozen=True)
class StateChanged:
    state: SessionState


@dataclass(frozen=True)
class InstanceLossPending:
    pass


XrEvent = StateChanged | InstanceLossPending


@dataclass(frozen=True)
class Pose:
    """A located pose in tracking space: ``position`` (3,), ``orientation`` quaternion ``(x, y, z, w)``."""

    position: np.ndarray
    orientation: tuple[float, float, float, float]


@dataclass(frozen=True)
class ViewLocation:
    """One eye at the predicted display time: pose and ``fov`` ``(left, right, up, down)`` angles in rad."""

    pose: Pose
    fov: tuple[float, float, float, float]


@dataclass(frozen=True)
class XrFrame:
    """``xrWaitFrame``'s answer: predicted display time (s), ``should_render``, and ``period`` (s):
    the display's refresh period where the runtime says what it is (``XR_FB_display_refresh_rate``),
    else the predicted display period. A runtime's predicted period can follow the application's
    own pace (Monado's does: 16.7 ms up to 683 ms for a slow app), which would hide missed
    refreshes (issue 23 item 6)."""

    display_time: float
    period: float
    should_render: bool


class XrPort(Protocol):
    """What the backend needs from OpenXR; :class:`pedvr.xr.openxr.OpenXRPort` makes the real calls."""

    def poll_events(self) -> list[XrEvent]: ...

    def begin_session(self) -> None: ...

    def end_session(self) -> None: ...

    def request_exit(self) -> None: ...

    def wait_frame(self) -> XrFrame: ...

    def begin_frame(self) -> None: ...

    def locate_head(self, display_time: float) -> Pose | None: ...

    def locate_views(self, display_time: float) -> list[ViewLocation]: ...

    def sync_controls(self, *, focused: bool) -> Controls: ...

    def locate_hands(self, display_time: float) -> list[Pose | None]: ...

    def render_eye(self, index: int, draw: Callable[[object, tuple[int, int, int, int]], None]) -> None: ...

    def end_frame(self, *, display_time: float, views: list[ViewLocation] | None) -> None: ...

    def idle_wait(self) -> None: ...

    def runtime_facts(self) -> dict[str, Any]:
        """What ``pedvr xr check`` prints (:meth:`pedvr.xr.openxr.OpenXRPort.runtime_facts`)."""
        ...

    def close(self) -> None: ...


@dataclass
class SessionLogic:
    """The session state machine: what each ``XrEventDataSessionStateChanged`` means for the app."""

    port: XrPort
    state: SessionState = SessionState.IDLE
    running: bool = False
    exit_requested: bool = False
    lost: str | None = None
    history: list[SessionState] = field(default_factory=list)

    @property
    def focused(self) -> bool:
        return self.state == SessionState.FOCUSED

    @property
    def done(self) -> bool:
        return self.state == SessionState.EXITING or self.lost is not None

    def handle(self, event: XrEvent) -> None:
        if isinstance(event, InstanceLossPending):
            self.lost = "the OpenXR runtime is going away (instance loss pending); restart it and pedvr"
            self._stop()
            return
        self.state = event.state
        self.history.append(event.state)
        if event.state == SessionState.READY and not self.running:
            self.port.begin_session()
            self.running = True
        elif event.state == SessionState.STOPPING:
            self._stop()
        elif event.state == SessionState.LOSS_PENDING:
            self.lost = "the headset was lost (session loss pending): reconnect it and run again"
            self._stop()
        elif event.state == SessionState.EXITING:
            self.running = False

    def _stop(self) -> None:
        if self.running:
            self.port.end_session()
            self.running = False

    def request_exit(self) -> None:
        """Ask the runtime to end the session (Esc, window closed, duration reached)."""
        if self.running and not self.exit_requested:
            self.port.request_exit()
            self.exit_requested = True


class XrPresenter:
    """The OpenXR presenter (module docstring). ``draw_eye(eye, framebuffer, viewport)`` draws one eye."""

    name = "xr"

    def __init__(
        self,
        port: XrPort,
        *,
        user: HeadsetUser,
        draw_eye: Callable[[EyeView, object, tuple], None],
        near: float = NEAR,
        far: float = FAR,
        update: Callable[[Simulation], None] | None = None,
    ) -> None:
        self.port = port
        self.user = user
        self.draw_eye = draw_eye
        self.update = update
        self.near, self.far = near, far
        self.logic = SessionLogic(port)
        self._frame: XrFrame | None = None
        self._begun = False  # xrBeginFrame called for self._frame
        self._views: list[ViewLocation] | None = None
        self._last_time: float | None = None
        self.controls = Controls()
        self.hands: list[Pose | None] = [None, None]  # grip poses (left, right), tracking space
        self.door_hand = 1  # the hand on a door: the one whose trigger took it (right until then)
        self.triggers = 0
        self.menus = 0
        self.holding_door = False
        self.eyes_rendered = [0, 0]  # frames drawn into each eye's swapchain
        self.focused_frames = 0
        self.facts: dict[str, Any] | None = None  # the runtime's facts, read once focused for a while

    @property
    def closed(self) -> bool:
        return self.logic.done

    @property
    def lost(self) -> str | None:
        return self.logic.lost

    def _lose(self, exc: RuntimeLostError) -> None:
        self.logic.lost = str(exc)
        self.logic.running = False  # the runtime is gone: nothing to end
        self._frame = None

    def wait_frame(self) -> FrameTiming | None:
        try:
            return self._wait_frame()
        except RuntimeLostError as exc:
            self._lose(exc)
            return None

    def _wait_frame(self) -> FrameTiming | None:
        if self._frame is not None:
            self._end_pending()  # a frame left open (an interrupt between wait and end): close it
        for ev in self.port.poll_events():
            self.logic.handle(ev)
        if not self.logic.running:
            if not self.logic.done:
                self.port.idle_wait()
            return None
        frame = self.port.wait_frame()
        self._frame, self._begun = frame, False
        self.port.begin_frame()
        self._begun = True
        head = self.port.locate_head(frame.display_time)
        self.controls = self.port.sync_controls(focused=self.logic.focused)
        self.hands = self.port.locate_hands(frame.display_time)
        self.triggers += int(self.controls.trigger)
        self.menus += int(self.controls.menu)
        if self.logic.focused:
            self.focused_frames += 1
            if self.facts is None and self.focused_frames >= FACTS_AFTER_FRAMES:
                self.facts = self.port.runtime_facts()
        dt = 0.0 if self._last_time is None else max(0.0, frame.display_time - self._last_time)
        self._last_time = frame.display_time
        self.user.track(
            t=frame.display_time,
            position=head.position if head else np.zeros(3),
            orientation=head.orientation if head else None,
            controls=self.controls,
            dt=dt,
        )
        self._views = self.port.locate_views(frame.display_time) if frame.should_render else None
        return FrameTiming(
            display_time=frame.display_time,
            period=frame.period,
            should_render=frame.should_render and bool(self._views),
        )

    def eye_views(self) -> list[EyeView]:
        """World-space views of the located eyes: tracking pose through the play space, off-axis frusta."""
        out = []
        for v in self._views or []:
            r, p = self.user.eye_world_pose(
                rotation=quat_to_matrix(*v.pose.orientation), position=v.pose.position
            )
            left, right, up, down = v.fov
            proj = projection_from_fov(
                angle_left=left, angle_right=right, angle_up=up, angle_down=down, near=self.near, far=self.far
            )
            out.append(EyeView.from_pose(rotation=r, position=p, projection=proj))
        return out

    def hand_point(self) -> tuple[float, float] | None:
        """The world floor point of the controller on the door (:attr:`door_hand`), or None when its
        grip pose is not tracked (the etiquette then assumes a reach ahead of the user, as on the
        desktop). A trigger press by a known hand makes that hand the door hand."""
        if self.controls.trigger and self.controls.trigger_hand in (0, 1):
            self.door_hand = self.controls.trigger_hand
        pose = self.hands[self.door_hand] if self.door_hand < len(self.hands) else None
        return None if pose is None else self.user.floor_point(pose.position)

    def render(self, sim: Simulation) -> None:
        if sim is not None and sim.etiquette is not None:
            # Issue 14: the trigger takes (or lets go of) the door whose handle is near the controller
            # that pressed it; while held, the leaf follows that controller every frame.
            hand = self.hand_point()
            if self.controls.trigger:
                self.holding_door = sim.etiquette.user_hand(not self.holding_door, hand)
            else:
                self.holding_door = sim.etiquette.user_hand_moved(hand)
        if self.update is not None:
            self.update(sim)
        try:
            for i, eye in enumerate(self.eye_views()):
                self.port.render_eye(i, self._drawer(eye))
                if i < len(self.eyes_rendered):
                    self.eyes_rendered[i] += 1
        except RuntimeLostError as exc:
            self._lose(exc)

    def _drawer(self, eye: EyeView) -> Callable[[object, tuple[int, int, int, int]], None]:
        def draw(framebuffer: object, viewport: tuple[int, int, int, int]) -> None:
            self.draw_eye(eye, framebuffer, viewport)

        return draw

    def end_frame(self) -> None:
        if self._frame is None:
            return
        frame, self._frame = self._frame, None
        try:
            if not self._begun:
                self.port.begin_frame()
            self.port.end_frame(
                display_time=frame.display_time, views=self._views if frame.should_render else None
            )
        except RuntimeLostError as exc:
            self._lose(exc)

    def _end_pending(self) -> None:
        """End a frame that was waited for but not ended, with no layers (nothing half-drawn shown)."""
        self._views = None
        self.end_frame()

    def request_exit(self) -> None:
        try:
            self.logic.request_exit()
        except RuntimeLostError as exc:
            self._lose(exc)

    def finish(self, *, timeout: float = 5.0, clock: Callable[[], float] | None = None) -> None:
        """End the session politely: close a frame left open, ask the runtime to exit, and keep
        submitting empty frames until it says EXITING (at most ``timeout`` s). Never raises for a
        lost runtime: :attr:`lost` says so instead."""
        import time

        tick = clock or time.perf_counter
        if self._frame is not None:
            self._end_pending()
        if self.closed:
            return
        if self.facts is None and self.logic.running:  # a short run: read them before the session ends
            try:
                self.facts = self.port.runtime_facts()
            except RuntimeLostError as exc:
                self._lose(exc)
                return
        self.request_exit()
        deadline = tick() + timeout
        while not self.closed and tick() < deadline:
            if self.wait_frame() is not None:
                self._end_pending()

    def close(self) -> None:
        self.port.close()
