"""The in-app study participant (``pedvr study run --backend desktop|xr``).

:class:`InAppParticipant` implements :class:`pedvr.study.presenter.Participant`
over a :class:`Frontend`: instruction pages and questions are text panels drawn
in the view (:mod:`pedvr.render.panel`: centred in front of the eyes, in each
eye in the headset) and answered through the pure state machines of
:mod:`pedvr.study.panel_input`; a trial runs the scene with the backend's own
user input (WASD and mouse on the desktop, the tracked head and thumbstick in
the headset) instead of the scripted walk.

Two frontends: :class:`DesktopFrontend` (a glfw window; keys and mouse as
listed in :mod:`pedvr.study.panel_input`) and :class:`XrFrontend` (an OpenXR
session through :class:`~pedvr.xr.session.XrPresenter`; thumbstick left/right
chooses, the trigger selects and confirms, the menu button goes back). Both
open once per session; each trial builds a renderer for its scene.

Closing the window, Esc, or the runtime ending the XR session aborts the
session like Ctrl-C (the runner records the abort; continue with ``--resume``).

While a panel waits for the participant, the experimenter's console keys still
work (issue 23 item 3: with a controller that cannot press, Ctrl-C was the only
way out): help prints, skip and abort end the panel and the runner handles them
as between steps (:class:`~pedvr.study.presenter.ExperimenterCommand`). Pause
stops the frames while it lasts, as it does in a trial.

Once an OpenXR session is focused, the runtime's facts (``pedvr xr check``'s:
runtime, headset, resolution, refresh rate, spaces, bound controllers) are
stored with the session's records, as an ``xr_runtime`` event whose detail is
their JSON (a methods section needs them).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from pedvr.errors import BackendUnavailableError
from pedvr.render.math3d import EYE_HEIGHT
from pedvr.render.panel import PanelAnchor, PanelDrawer, PanelImage, panel_image, row_at
from pedvr.study.panel_input import PagePanel, PanelEvent, PanelView, QuestionPanel, drive
from pedvr.study.presenter import ExperimenterCommand, HeadPose, Page, Question, head_from_floor
from pedvr.study.questionnaire import Response

if TYPE_CHECKING:
    from pedvr.crowd.user import UserInput
    from pedvr.scene.config import SceneConfig
    from pedvr.sim import Simulation
    from pedvr.study.console import ExperimenterConsole
    from pedvr.study.protocol import TrialSpec

STICK_FIRE = 0.7  # thumbstick x beyond this chooses the next / previous option ...
STICK_ARM = 0.3  # ... once it has come back inside this


class Frontend(Protocol):
    """A backend as the in-app participant uses it: one frame at a time, input as panel events."""

    name: str
    keyboard: bool

    @property
    def closed(self) -> bool: ...

    def begin_trial(self, scene: SceneConfig) -> UserInput:
        """Build the trial's view of ``scene``; return the user input that moves the user agent."""
        ...

    def frame(self, sim: Simulation | None, panel: PanelView | None) -> tuple[float | None, list[PanelEvent]]:
        """Make one frame: the scene of ``sim`` (or a plain background) and ``panel`` over it.

        Returns the frame's display time (s, the frontend's clock; None when no frame could be
        made, e.g. an idle XR session) and the panel events since the last frame.
        """
        ...

    def head_pose(self, sim: Simulation) -> HeadPose: ...

    def runtime_facts(self) -> dict[str, Any] | None:
        """The XR runtime's facts once they are all known (session focused), else None."""
        ...

    def close(self) -> None: ...


class SessionClosed(KeyboardInterrupt):
    """The participant closed the window or the XR session ended: the runner aborts (resumable)."""


class InAppParticipant:
    """The participant in the app (module docstring). ``max_lag`` as in :func:`pedvr.xr.loop.run_frames`;
    ``console``: the experimenter's, polled while panels wait and told the runtime's facts."""

    def __init__(self, frontend: Frontend, *, max_lag: float = 0.25,
                 console: ExperimenterConsole | None = None) -> None:
        self.frontend = frontend
        self.kind = f"in-app ({frontend.name})"
        self.user_walk: str | None = None  # a real person walks (trial_input gives the pose source)
        self.max_lag = max_lag
        self.console = console
        self._origin: float | None = None
        self._facts_logged = False

    def _check(self) -> None:
        if self.frontend.closed:
            raise SessionClosed(f"the {self.frontend.name} view was closed")
        self._log_runtime()

    def _log_runtime(self) -> None:
        """Store the runtime's facts with the session once, when the frontend knows them all."""
        if self._facts_logged or self.console is None:
            return
        facts = self.frontend.runtime_facts()
        if facts is not None:
            self.console.on_event("xr_runtime", json.dumps(facts, sort_keys=True))
            self._facts_logged = True

    def _run(self, panel: PagePanel | QuestionPanel) -> None:
        while not panel.done:
            self._check()
            _, events = self.frontend.frame(None, panel.view())
            drive(panel, events)  # events after the confirming one are dropped, not given to the next panel
            if self.console is not None and not panel.done:
                cmd = self.console.check()  # help prints; pause waits; skip and abort end the panel
                if cmd is not None:
                    raise ExperimenterCommand(cmd)

    def show(self, page: Page) -> None:
        self._run(PagePanel(page, keyboard=self.frontend.keyboard))

    def ask(self, question: Question) -> Response:
        panel = QuestionPanel(question, keyboard=self.frontend.keyboard)
        self._run(panel)
        assert panel.response is not None
        return panel.response

    def trial_input(self, *, trial: TrialSpec, scene: SceneConfig) -> UserInput | None:
        self._origin = None
        return self.frontend.begin_trial(scene)

    def present(self, sim: Simulation) -> float:
        while True:
            self._check()
            shown, _ = self.frontend.frame(sim, None)
            if shown is not None:
                break
        if self._origin is None:
            self._origin = shown - sim.t
        target = shown - self._origin
        if target - sim.t > self.max_lag:  # a stall: skip ahead rather than run a burst of steps
            self._origin += target - sim.t - self.max_lag
            target = sim.t + self.max_lag
        return target  # the runner steps at least once per frame

    def head_pose(self, sim: Simulation) -> HeadPose:
        return self.frontend.head_pose(sim)

    def close(self) -> None:
        self.frontend.close()


def _qmul(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def head_with_pitch(base: HeadPose, *, heading: float, pitch: float) -> HeadPose:
    """``base`` (yaw only) looking up by ``pitch`` rad: a rotation about the head's horizontal axis."""
    ax = (math.sin(heading), -math.cos(heading), 0.0)  # forward x axis = +z (looking up)
    s = math.sin(pitch / 2)
    q = _qmul((math.cos(pitch / 2), ax[0] * s, ax[1] * s, 0.0), base.orientation)
    return HeadPose(position=base.position, orientation=q)


# -- the desktop frontend -----------------------------------------------------------------------


class DesktopFrontend:
    """A glfw window: the first-person view, WASD/mouse in trials, keys and mouse on the panels."""

    name = "desktop"
    keyboard = True

    def __init__(
        self,
        *,
        width: int = 1280,
        height: int = 720,
        vsync: bool = True,
        visible: bool = True,
        eye_height: float = EYE_HEIGHT,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        from pedvr.xr.desktop import open_gl_window

        self.glfw, self.window, self.ctx = open_gl_window(width, height, "pedvr study",
                                                          visible=visible, vsync=vsync)
        glfw = self.glfw
        self.drawer = PanelDrawer(self.ctx)
        self.eye_height = eye_height
        self.clock = clock
        monitor = glfw.get_primary_monitor()
        mode = glfw.get_video_mode(monitor) if monitor else None
        self.period = 1.0 / (mode.refresh_rate if mode and mode.refresh_rate else 60.0)
        self.renderer: Any = None
        self.composer: Any = None
        self.user: Any = None
        self._events: list[PanelEvent] = []
        self._panel_mode = True
        self._panel: tuple[PanelImage, tuple[int, int, int, int], PanelView] | None = None
        self._closed = False
        self._captured = False
        self._cursor: tuple[float, float] | None = None
        glfw.set_key_callback(self.window, self._on_key)
        glfw.set_char_callback(self.window, self._on_char)
        glfw.set_mouse_button_callback(self.window, self._on_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)

    # -- input -------------------------------------------------------------------------------

    def _on_key(self, window: Any, key: int, scancode: int, action: int, mods: int) -> None:
        g = self.glfw
        if action not in (g.PRESS, g.REPEAT):
            return
        if key == g.KEY_ESCAPE and action == g.PRESS:
            self._closed = True
        elif key == g.KEY_TAB:
            self._capture(False)
        elif self._panel_mode:
            kind = {
                g.KEY_LEFT: "prev",
                g.KEY_UP: "prev",
                g.KEY_RIGHT: "next",
                g.KEY_DOWN: "next",
                g.KEY_ENTER: "select",
                g.KEY_KP_ENTER: "select",
                g.KEY_BACKSPACE: "back",
                g.KEY_Y: "confirm",
            }.get(key)
            if kind is not None and not (kind in ("select", "confirm") and action != g.PRESS):
                self._events.append(PanelEvent(kind))

    def _on_char(self, window: Any, codepoint: int) -> None:
        if self._panel_mode:
            self._events.append(PanelEvent("char", chr(codepoint)))

    def _fb_scale(self) -> tuple[float, float]:
        w, h = self.glfw.get_window_size(self.window)
        fw, fh = self.glfw.get_framebuffer_size(self.window)
        return (fw / w if w else 1.0), (fh / h if h else 1.0)

    def _on_button(self, window: Any, button: int, action: int, mods: int) -> None:
        g = self.glfw
        if action != g.PRESS:
            return
        if not self._panel_mode:
            self._capture(True)
            return
        if button == g.MOUSE_BUTTON_RIGHT:
            self._events.append(PanelEvent("back"))
        elif button == g.MOUSE_BUTTON_LEFT and self._panel is not None:
            img, rect, view = self._panel
            cx, cy = g.get_cursor_pos(self.window)
            sx, sy = self._fb_scale()
            row = row_at(img, rect, cx * sx, cy * sy)
            if row is None:
                return
            if row in view.option_rows:
                self._events.append(PanelEvent("pick", view.option_rows[row]))
            self._events.append(PanelEvent("select"))

    def _capture(self, on: bool) -> None:
        g = self.glfw
        g.set_input_mode(self.window, g.CURSOR, g.CURSOR_DISABLED if on else g.CURSOR_NORMAL)
        self._captured = on
        self._cursor = None

    def _on_cursor(self, window: Any, x: float, y: float) -> None:
        from pedvr.xr.desktop import MOUSE_SENSITIVITY

        if self._captured and self._cursor is not None and self.user is not None and not self._panel_mode:
            self.user.look(
                yaw=(x - self._cursor[0]) * MOUSE_SENSITIVITY,
                pitch=-(y - self._cursor[1]) * MOUSE_SENSITIVITY,
            )
        self._cursor = (x, y)

    def _walk_keys(self) -> None:
        g = self.glfw

        def down(*keys: int) -> bool:
            return any(g.get_key(self.window, k) == g.PRESS for k in keys)

        if self.user is None:
            return
        if self._panel_mode:
            self.user.set_keys(forward=0.0, strafe=0.0, fast=False)
            return
        self.user.set_keys(
            forward=float(down(g.KEY_W, g.KEY_UP)) - float(down(g.KEY_S, g.KEY_DOWN)),
            strafe=float(down(g.KEY_D, g.KEY_RIGHT)) - float(down(g.KEY_A, g.KEY_LEFT)),
            fast=down(g.KEY_LEFT_SHIFT, g.KEY_RIGHT_SHIFT),
        )

    # -- Frontend ----------------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        return self._closed or self.window is None or bool(self.glfw.window_should_close(self.window))

    def begin_trial(self, scene: SceneConfig) -> UserInput:
        from pedvr.render.renderer import Renderer
        from pedvr.render.views import ViewComposer
        from pedvr.xr.locomotion import KeyboardMouseUser, WalkableArea

        self._release_trial()
        self.renderer = Renderer.for_scene(self.ctx, scene)
        self.composer = ViewComposer(self.renderer)
        self.user = KeyboardMouseUser(
            start=scene.user.start,
            heading=scene.user.heading,
            walkable=WalkableArea(scene.world, radius=scene.user.radius),
        )
        return self.user

    def frame(self, sim: Simulation | None, panel: PanelView | None) -> tuple[float | None, list[PanelEvent]]:
        g = self.glfw
        entering_panel = panel is not None and not self._panel_mode
        self._panel_mode = panel is not None
        if entering_panel and self._captured:
            self._capture(False)
        g.poll_events()
        self._walk_keys()
        now = self.clock()
        fw, fh = g.get_framebuffer_size(self.window)
        if fw > 0 and fh > 0:
            fb = self.ctx.screen
            vp = (0, 0, fw, fh)
            if sim is not None and self.composer is not None:
                from pedvr.render.snapshot import Snapshot

                snap = Snapshot.from_sim(sim)
                self.renderer.begin_frame()
                self.renderer.update(snap)
                u = snap.user_row
                self.composer.draw(
                    "mono",
                    framebuffer=fb,
                    viewport=vp,
                    pos=snap.pos[u] if u is not None else self.user.pos,
                    heading=float(snap.heading[u]) if u is not None else self.user.heading,
                    pitch=self.user.pitch,
                    eye_height=self.eye_height,
                )
            else:
                self.drawer.clear(fb, vp)
            if panel is not None:
                img = panel_image(
                    panel.lines,
                    highlight=panel.highlight,
                    title_rows=panel.title_rows,
                    font_size=max(14, fh // 34),
                )
                rect = self.drawer.draw(img, framebuffer=fb, viewport=vp)
                self._panel = (img, rect, panel)
            else:
                self._panel = None
            g.swap_buffers(self.window)
        events, self._events = self._events, []
        return now + self.period, events if panel is not None else []

    def runtime_facts(self) -> dict[str, Any] | None:
        return None  # no XR runtime on the desktop

    def head_pose(self, sim: Simulation) -> HeadPose:
        base = head_from_floor(sim, eye_height_m=self.eye_height)
        pitch = self.user.pitch if self.user is not None else 0.0
        return head_with_pitch(base, heading=float(sim.crowd.heading[0]), pitch=pitch)

    def _release_trial(self) -> None:
        if self.composer is not None:
            self.composer.release()
            self.renderer.release()
        self.renderer = self.composer = self.user = None

    def close(self) -> None:
        if self.window is None:
            return
        self._release_trial()
        self.drawer.release()
        self.ctx.release()
        self.glfw.destroy_window(self.window)
        self.window = None
        self.glfw.terminate()


# -- the OpenXR frontend ------------------------------------------------------------------------


class StickChooser:
    """Thumbstick x to ``prev``/``next``: fires past :data:`STICK_FIRE`, re-arms inside :data:`STICK_ARM`."""

    def __init__(self) -> None:
        self.armed = True

    def feed(self, x: float) -> list[PanelEvent]:
        if abs(x) < STICK_ARM:
            self.armed = True
        elif self.armed and abs(x) > STICK_FIRE:
            self.armed = False
            return [PanelEvent("next" if x > 0 else "prev")]
        return []


def controller_events(controls: Any, stick: StickChooser) -> list[PanelEvent]:
    """One frame of :class:`~pedvr.xr.locomotion.Controls` as panel events (either stick chooses)."""
    x = max(controls.move[0], controls.turn, key=abs)
    out = stick.feed(float(x))
    if controls.trigger:
        out.append(PanelEvent("select"))
    if controls.menu:
        out.append(PanelEvent("back"))
    return out


REANCHOR_DEG = 70.0  # turn further than this from a panel and it is put in front again


class XrFrontend:
    """An OpenXR session: the scene per eye, the panel in both eyes, the controller on the panels.

    ``port`` is an :class:`~pedvr.xr.session.XrPort` (the real :class:`~pedvr.xr.openxr.OpenXRPort`
    by default; a fake in tests, with ``drawer=None`` to draw nothing).

    Panels are fixed in the world, not to the head (head-locked text is uncomfortable to read
    in a headset): a page appears :data:`~pedvr.render.panel.PANEL_DISTANCE` ahead of where the
    participant looks, level, and stays there through the pages that follow; it moves in front
    of them again only when they turn more than :data:`REANCHOR_DEG` away from it.
    """

    name = "xr"
    keyboard = False

    def __init__(self, *, eye_height: float = EYE_HEIGHT, port: Any = None, drawer: Any = "auto") -> None:
        from pedvr.xr.locomotion import HeadsetUser
        from pedvr.xr.session import XrPresenter

        if port is None:
            from pedvr.xr.openxr import OpenXRPort

            port = OpenXRPort.open()
        self.port = port
        self.srgb = bool(getattr(port, "srgb", False))
        self.ctx = getattr(port, "ctx", None)
        if drawer == "auto":
            drawer = PanelDrawer(self.ctx) if self.ctx is not None else None
        self.drawer = drawer
        self.eye_height = eye_height
        self._panel_user = HeadsetUser(start=(0.0, 0.0), heading=0.0)  # panels: locomotion moves nothing
        self.user: Any = None
        self.renderer: Any = None
        self.presenter = XrPresenter(port, user=self._panel_user, draw_eye=self._draw_eye)
        self._stick = StickChooser()
        self._sim: Simulation | None = None
        self._panel_img: PanelImage | None = None
        self.anchor: PanelAnchor | None = None
        self._frame = 0
        self._anchor_checked = -1

    @property
    def closed(self) -> bool:
        return self.presenter.closed

    def _place_panel(self, eye: Any) -> PanelAnchor:
        """The panel's anchor for this frame: kept, or put in front of ``eye`` (first time, or
        once a frame when the participant has turned too far away from it)."""
        if self.anchor is None:
            self.anchor = PanelAnchor.facing(eye.view, eye.position)
        elif self._anchor_checked != self._frame:
            to_panel = self.anchor.center - np.asarray(eye.position, np.float64)
            fwd = -np.asarray(eye.view, np.float64)[2, :3]
            a = np.array([to_panel[0], to_panel[2]])
            b = np.array([fwd[0], fwd[2]])
            cos = float(a @ b / max(np.linalg.norm(a) * np.linalg.norm(b), 1e-9))
            if cos < np.cos(np.radians(REANCHOR_DEG)):
                self.anchor = PanelAnchor.facing(eye.view, eye.position)
        self._anchor_checked = self._frame
        return self.anchor

    def begin_trial(self, scene: SceneConfig) -> UserInput:
        from pedvr.xr.locomotion import HeadsetUser, WalkableArea

        self._release_trial()
        if self.ctx is not None:
            from pedvr.render.renderer import Renderer

            self.renderer = Renderer.for_scene(self.ctx, scene)
        self.user = HeadsetUser(
            start=scene.user.start,
            heading=scene.user.heading,
            walkable=WalkableArea(scene.world, radius=scene.user.radius),
        )
        return self.user

    def _draw_eye(self, eye: Any, fbo: Any, viewport: tuple[int, int, int, int]) -> None:
        if self._sim is not None and self.renderer is not None:
            self.renderer.draw_scene([eye], framebuffer=fbo, viewport=viewport, srgb_encode=not self.srgb)
            if self.user is not None:
                self.renderer.draw_vignette(
                    min(1.0, self.user.moving_speed / 1.3) * 0.6, framebuffer=fbo, viewport=viewport
                )
        elif self.drawer is not None:
            self.drawer.clear(fbo, viewport)
        if self._panel_img is not None:
            anchor = self._place_panel(eye)
            if self.drawer is not None:
                self.drawer.draw_world(self._panel_img, anchor, view_projection=eye.view_projection,
                                       framebuffer=fbo, viewport=viewport, linear_target=self.srgb)

    def frame(self, sim: Simulation | None, panel: PanelView | None) -> tuple[float | None, list[PanelEvent]]:
        in_trial = panel is None and self.user is not None
        self.presenter.user = self.user if in_trial else self._panel_user
        timing = self.presenter.wait_frame()
        if timing is None:
            return None, []
        self._frame += 1
        if panel is None:
            self.anchor = None  # the next page is placed where the participant looks then
        events = controller_events(self.presenter.controls, self._stick) if panel is not None else []
        self._sim = sim
        self._panel_img = (
            panel_image(
                panel.lines,
                highlight=panel.highlight,
                title_rows=panel.title_rows,
                width_px=1024,
                font_size=30,
            )
            if panel is not None
            else None
        )
        if timing.should_render:
            if sim is not None and self.renderer is not None:
                from pedvr.render.snapshot import Snapshot

                self.renderer.begin_frame()
                self.renderer.update(Snapshot.from_sim(sim))
            self.presenter.render(sim)  # type: ignore[arg-type]
        self.presenter.end_frame()
        return timing.display_time, events

    def head_pose(self, sim: Simulation) -> HeadPose:
        return head_from_floor(sim, eye_height_m=self.eye_height)

    def runtime_facts(self) -> dict[str, Any] | None:
        """The port's :meth:`~pedvr.xr.openxr.OpenXRPort.runtime_facts` once the session has been
        focused for a few frames (the controllers' profiles are bound by then), else None."""
        return self.presenter.facts

    def _release_trial(self) -> None:
        if self.renderer is not None:
            self.renderer.release()
        self.renderer = self.user = None

    def close(self) -> None:
        try:
            self.presenter.finish()
        finally:
            self._release_trial()
            if self.drawer is not None:
                self.drawer.release()
            self.presenter.close()


def prepare_protocol(protocol: Any, *, say: Callable[[str], None] | None = None) -> int:
    """Prepare the protocol's trials before the view opens (:mod:`pedvr.prepare`): a trial's first
    step inside a running headset session would freeze it while numba compiles (issue 23 item 2).

    Each distinct (scene, condition) of participant 1's plan gets a simulation of its own and its
    first steps with both kernel twins; once one of them compiles nothing, numba's cache is warm
    and the rest are skipped (a warm start costs one scene's set-up). Returns the number prepared.
    Kernels a trial needs only later (an event minutes in) still compile when first used."""
    from pedvr.prepare import first_step, stderr_say, twin_steps
    from pedvr.scene.loader import load_any
    from pedvr.sim import Simulation
    from pedvr.study.protocol import plan_for

    say = stderr_say if say is None else say
    seen: set[tuple[str, str]] = set()
    specs = []
    for step in plan_for(protocol, number=1):
        spec = step.trial
        if spec is not None and (spec.scene, spec.condition) not in seen:
            seen.add((spec.scene, spec.condition))
            specs.append(spec)
    for k, spec in enumerate(specs, start=1):
        say(f"preparing trial scene {k} of {len(specs)}: {spec.scene_name} ({spec.condition}) ...")
        scene = load_any(protocol.scene_path(spec.scene), seed=spec.seed)
        sim = Simulation(scene, seed=spec.seed, condition=spec.condition, responsibility=spec.responsibility)
        compiled = first_step(sim, say=say).kernels_compiled + twin_steps(sim, say=say)[0]
        if compiled == 0:
            say("prepared: numba's cache is warm")
            return k
    return len(specs)


def open_frontend(backend: str, *, eye_height: float) -> DesktopFrontend | XrFrontend:
    """The frontend for ``backend`` (``desktop`` or ``xr``); raises BackendUnavailableError (one line)."""
    if backend == "desktop":
        return DesktopFrontend(eye_height=eye_height)
    if backend == "xr":
        return XrFrontend(eye_height=eye_height)
    raise BackendUnavailableError(f"backend {backend!r}: the in-app participant runs on desktop or xr")


__all__ = [
    "DesktopFrontend",
    "Frontend",
    "InAppParticipant",
    "SessionClosed",
    "StickChooser",
    "XrFrontend",
    "controller_events",
    "head_with_pitch",
    "open_frontend",
    "prepare_protocol",
]
