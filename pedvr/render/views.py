"""Desktop and file views of the scene: mono, side-by-side stereo, anaglyph, overhead debug.

The first-person camera sits at the user's eyes (PedVR §3.6), eye height
from the user's body; stereo uses two parallel eyes 63 mm apart with
symmetric frusta (issue 4), drawn in one pass. The HUD (fps, frame ms, the
blind condition label) is drawn on top of the first-person views.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from pedvr.errors import UsageError
from pedvr.render.math3d import EYE_HEIGHT, IPD, desktop_stereo_eyes, first_person_eye
from pedvr.render.renderer import OffscreenTarget, Renderer
from pedvr.render.text import Hud

VIEW_MODES = ("mono", "sbs", "anaglyph", "overhead")
FOVY = math.radians(70.0)


class ViewComposer:
    """Draws one of :data:`VIEW_MODES` into a framebuffer viewport with a :class:`Renderer`."""

    def __init__(self, renderer: Renderer, *, ipd: float = IPD, fovy: float = FOVY) -> None:
        self.renderer = renderer
        self.ipd = ipd
        self.fovy = fovy
        self._stereo: OffscreenTarget | None = None

    def draw(
        self,
        mode: str,
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        pos: np.ndarray,
        heading: float,
        pitch: float = 0.0,
        eye_height: float = EYE_HEIGHT,
        hud: Hud | None = None,
    ) -> None:
        """Draw ``mode`` for a user at ground ``pos`` facing ``heading``, looking up by ``pitch``."""
        if mode not in VIEW_MODES:
            raise UsageError(f"view {mode!r}: expected one of {', '.join(VIEW_MODES)}")
        r = self.renderer
        x, y, w, h = viewport
        if mode == "overhead":
            r.draw_overhead(framebuffer=framebuffer, viewport=viewport)
            return
        if mode == "mono":
            eye = first_person_eye(
                pos=pos, heading=heading, pitch=pitch, eye_height=eye_height, fovy=self.fovy, aspect=w / h
            )
            r.draw_scene([eye], framebuffer=framebuffer, viewport=viewport)
        elif mode == "sbs":
            eyes = desktop_stereo_eyes(
                pos=pos,
                heading=heading,
                pitch=pitch,
                eye_height=eye_height,
                ipd=self.ipd,
                fovy=self.fovy,
                aspect=(w / 2) / h,
            )
            r.draw_scene(list(eyes), framebuffer=framebuffer, viewport=viewport)
        else:
            if self._stereo is None or self._stereo.size != (2 * w, h):
                if self._stereo is not None:
                    self._stereo.release()
                self._stereo = OffscreenTarget(r.ctx, (2 * w, h))
            eyes = desktop_stereo_eyes(
                pos=pos,
                heading=heading,
                pitch=pitch,
                eye_height=eye_height,
                ipd=self.ipd,
                fovy=self.fovy,
                aspect=w / h,
            )
            r.draw_scene(list(eyes), framebuffer=self._stereo.fbo)
            r.draw_anaglyph(self._stereo.resolved, framebuffer=framebuffer, viewport=viewport)
        if hud is not None:
            r.draw_panel(hud.image(), framebuffer=framebuffer, viewport=viewport, x=6, y=6)

    def release(self) -> None:
        if self._stereo is not None:
            self._stereo.release()
            self._stereo = None
