"""The desktop backend: a glfw window, keyboard and mouse (PedVR §6.2: the study's participants
moved with a mouse and keyboard).

Keys: W A S D or the arrows walk at 1.3 m/s (Shift: twice as fast); the
mouse turns and looks up and down once the window has captured it (click;
Tab releases it; until the first click a line at the bottom says so); 1 mono,
2 side-by-side stereo, 3 anaglyph, 4 overhead debug view; H toggles the HUD;
F11 full screen; Esc quits. Vsync is on by default, so frames follow the
monitor's refresh.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from pedvr.errors import BackendUnavailableError, UsageError
from pedvr.render.math3d import EYE_HEIGHT
from pedvr.render.renderer import Renderer
from pedvr.render.snapshot import Snapshot
from pedvr.render.text import Hud, text_panel
from pedvr.render.views import VIEW_MODES, ViewComposer
from pedvr.scene.config import SceneConfig
from pedvr.xr.locomotion import KeyboardMouseUser
from pedvr.xr.loop import FrameTiming

if TYPE_CHECKING:
    from pedvr.sim import Simulation

MOUSE_SENSITIVITY = 0.0025  # rad per pixel
CAPTURE_HINT = "Click in the window to look around with the mouse (Tab releases it)"
MODE_KEYS = {"1": "mono", "2": "sbs", "3": "anaglyph", "4": "overhead"}


def display_missing() -> str | None:
    """None when glfw can reach a display; else one line saying why not (no window is opened)."""
    import os

    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display (DISPLAY is not set)"
    try:
        import glfw
    except ImportError:
        return "glfw is not installed (pip install glfw)"
    saved = glfw.ERROR_REPORTING
    glfw.ERROR_REPORTING = "ignore"  # the answer is the line below, not glfw's warnings
    try:
        ok = glfw.init()
    finally:
        glfw.ERROR_REPORTING = saved
    if not ok:
        where = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        return f"glfw cannot connect to the display {where}"
    return None


def open_gl_window(width: int, height: int, title: str, *, visible: bool,
                   vsync: bool) -> tuple[Any, Any, Any]:
    """A glfw window with an OpenGL 3.3 core context: ``(glfw module, window, moderngl context)``.

    Raises BackendUnavailableError (one line) when there is no display or no
    such context. glfw must not be initialised twice: callers own ``terminate``.
    """
    why = display_missing()
    if why is not None:
        raise BackendUnavailableError(f"cannot open a desktop window: {why}; use --backend headless")
    import glfw
    import moderngl

    for hint, value in (
        (glfw.CONTEXT_VERSION_MAJOR, 3),
        (glfw.CONTEXT_VERSION_MINOR, 3),
        (glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE),
        (glfw.OPENGL_FORWARD_COMPAT, glfw.TRUE),
        (glfw.VISIBLE, glfw.TRUE if visible else glfw.FALSE),
        (glfw.DEPTH_BITS, 24),
        (glfw.SAMPLES, 4),  # multisampling (issue 16)
    ):
        glfw.window_hint(hint, value)
    window = glfw.create_window(width, height, title, None, None)
    if not window:
        glfw.terminate()
        raise BackendUnavailableError(
            "cannot open a desktop window: no OpenGL 3.3 core context on this display; "
            "use --backend headless"
        )
    glfw.make_context_current(window)
    glfw.swap_interval(1 if vsync else 0)
    return glfw, window, moderngl.create_context(require=330)


class DesktopPresenter:
    """A window with the first-person view (or another of :data:`VIEW_MODES`) of the user at the keys."""

    name = "desktop"

    def __init__(
        self,
        scene: SceneConfig,
        *,
        user: KeyboardMouseUser,
        width: int = 1280,
        height: int = 720,
        view: str = "mono",
        hud_label: str | None = None,
        vsync: bool = True,
        visible: bool = True,
        eye_height: float = EYE_HEIGHT,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        if view not in VIEW_MODES:
            raise UsageError(f"--view {view!r}: expected one of {', '.join(VIEW_MODES)}")
        self.glfw, self.window, self.ctx = open_gl_window(width, height, f"pedvr: {scene.name}",
                                                          visible=visible, vsync=vsync)
        glfw = self.glfw
        self.renderer = Renderer.for_scene(self.ctx, scene)
        self.composer = ViewComposer(self.renderer)
        self.user = user
        self.mode = view
        self.hud = Hud(label=hud_label)
        self.show_hud = True
        self.eye_height = eye_height
        self.clock = clock
        self._closed = False
        self._captured = False
        self.show_capture_hint = True  # until the mouse is first captured (issue 11)
        self._cursor: tuple[float, float] | None = None
        self._windowed: tuple[int, int, int, int] | None = None
        self._last_frame: float | None = None
        monitor = glfw.get_primary_monitor()
        mode = glfw.get_video_mode(monitor) if monitor else None
        self.period = 1.0 / (mode.refresh_rate if mode and mode.refresh_rate else 60.0)
        self.door_presses = 0
        self.holding_door = False
        glfw.set_key_callback(self.window, self._on_key)
        glfw.set_mouse_button_callback(self.window, self._on_button)
        glfw.set_cursor_pos_callback(self.window, self._on_cursor)

    # -- input -----------------------------------------------------------------------------

    def _on_key(self, window: Any, key: int, scancode: int, action: int, mods: int) -> None:
        glfw = self.glfw
        if action != glfw.PRESS:
            return
        if key == glfw.KEY_ESCAPE:
            self._closed = True
        elif key == glfw.KEY_F11:
            self.toggle_fullscreen()
        elif key == glfw.KEY_TAB:
            self._capture(False)
        elif key == glfw.KEY_H:
            self.show_hud = not self.show_hud
        elif key == glfw.KEY_E:
            self.door_presses += 1  # take (or let go of) the door whose handle is within reach
        else:
            name = glfw.get_key_name(key, scancode)
            if name in MODE_KEYS:
                self.mode = MODE_KEYS[name]

    def _on_button(self, window: Any, button: int, action: int, mods: int) -> None:
        if action == self.glfw.PRESS:
            self._capture(True)

    def _capture(self, on: bool) -> None:
        glfw = self.glfw
        glfw.set_input_mode(self.window, glfw.CURSOR, glfw.CURSOR_DISABLED if on else glfw.CURSOR_NORMAL)
        self._captured = on
        if on:
            self.show_capture_hint = False
        # From here on motion is relative to where the (now virtual) cursor is, so the very first
        # movement after the click already turns the view.
        self._cursor = tuple(glfw.get_cursor_pos(self.window)) if on else None

    def _on_cursor(self, window: Any, x: float, y: float) -> None:
        if self._captured and self._cursor is not None:
            dx, dy = x - self._cursor[0], y - self._cursor[1]
            # Mouse right turns right; mouse up (smaller y) looks up.
            self.user.look(yaw=dx * MOUSE_SENSITIVITY, pitch=-dy * MOUSE_SENSITIVITY)
        self._cursor = (x, y)

    def _keys(self) -> None:
        glfw = self.glfw

        def down(*keys: int) -> bool:
            return any(glfw.get_key(self.window, k) == glfw.PRESS for k in keys)

        forward = float(down(glfw.KEY_W, glfw.KEY_UP)) - float(down(glfw.KEY_S, glfw.KEY_DOWN))
        strafe = float(down(glfw.KEY_D, glfw.KEY_RIGHT)) - float(down(glfw.KEY_A, glfw.KEY_LEFT))
        self.user.set_keys(
            forward=forward, strafe=strafe, fast=down(glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT)
        )

    def toggle_fullscreen(self) -> None:
        glfw = self.glfw
        monitor = glfw.get_primary_monitor()
        if not monitor:
            return
        if self._windowed is None:
            x, y = glfw.get_window_pos(self.window)
            w, h = glfw.get_window_size(self.window)
            self._windowed = (x, y, w, h)
            mode = glfw.get_video_mode(monitor)
            glfw.set_window_monitor(
                self.window, monitor, 0, 0, mode.size.width, mode.size.height, mode.refresh_rate
            )
        else:
            x, y, w, h = self._windowed
            self._windowed = None
            glfw.set_window_monitor(self.window, None, x, y, w, h, 0)

    # -- Presenter -------------------------------------------------------------------------

    @property
    def closed(self) -> bool:
        return self._closed or bool(self.glfw.window_should_close(self.window))

    def wait_frame(self) -> FrameTiming:
        self.glfw.poll_events()
        self._keys()
        now = self.clock()
        if self._last_frame is not None:
            dt = now - self._last_frame
            if dt > 0:
                self.hud.fps = 0.9 * self.hud.fps + 0.1 / dt if self.hud.fps else 1.0 / dt
                self.hud.frame_ms = 0.9 * self.hud.frame_ms + 100.0 * dt if self.hud.frame_ms else 1e3 * dt
        self._last_frame = now
        # Shown at the next vertical blank after the swap: about one period from now.
        return FrameTiming(display_time=now + self.period, period=self.period)

    def render(self, sim: Simulation) -> None:
        if self.door_presses and sim is not None and sim.etiquette is not None:  # E: a hand on a door
            for _ in range(self.door_presses):
                self.holding_door = sim.etiquette.user_hand(not self.holding_door)
        self.door_presses = 0
        snap = Snapshot.from_sim(sim)
        r = self.renderer
        r.begin_frame()
        r.update(snap)
        u = snap.user_row
        pos = snap.pos[u] if u is not None else self.user.pos
        heading = float(snap.heading[u]) if u is not None else self.user.heading
        fb = self.ctx.screen
        w, h = self.glfw.get_framebuffer_size(self.window)
        if w == 0 or h == 0:
            return  # minimised
        self.composer.draw(
            self.mode,
            framebuffer=fb,
            viewport=(0, 0, w, h),
            pos=pos,
            heading=heading,
            pitch=self.user.pitch,
            eye_height=self.eye_height,
            hud=self.hud if self.show_hud and self.mode != "overhead" else None,
        )
        if self.show_capture_hint:
            # Until the first click: how to capture the mouse, centred near the bottom (issue 11).
            img = text_panel([CAPTURE_HINT], font_size=max(10, min(18, w // 40)))
            x = max(0, (w - img.shape[1]) // 2)
            y = max(0, h - img.shape[0] - max(6, h // 12))
            self.renderer.draw_panel(img, framebuffer=fb, viewport=(0, 0, w, h), x=x, y=y)

    def end_frame(self) -> None:
        self.glfw.swap_buffers(self.window)

    def read_pixel(self, x: int, y: int) -> tuple[int, int, int]:
        """RGB of window pixel ``(x, y)`` (from the top-left) of the frame just rendered, before the swap."""
        w, h = self.glfw.get_framebuffer_size(self.window)
        data = self.ctx.screen.read(viewport=(x, h - 1 - y, 1, 1), components=3)
        return data[0], data[1], data[2]

    def close(self) -> None:
        if self.window is None:
            return
        self.composer.release()
        self.renderer.release()
        self.ctx.release()
        self.glfw.destroy_window(self.window)
        self.window = None
        self.glfw.terminate()
        self._closed = True
