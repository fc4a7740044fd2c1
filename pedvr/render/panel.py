"""The study's text panels in the view: Pillow image (reusing :mod:`pedvr.render.text`'s font), drawn
as a textured quad: centred in the window on a desktop (:meth:`PanelDrawer.draw`), or fixed in the
world in a headset (:meth:`PanelDrawer.draw_world` at a :class:`PanelAnchor`), seen through each
eye. Self-contained GL (it compiles ``shaders/panel.glsl`` itself), so it draws over any
framebuffer without a :class:`~pedvr.render.renderer.Renderer` (pages shown before the first trial
have no scene).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np
from PIL import Image, ImageDraw

from pedvr.render.shaders import SHADER_DIR, compile_program, set_uniform
from pedvr.render.text import _font

BACKGROUND = (12, 16, 24, 225)
FOREGROUND = (240, 240, 240, 255)
HIGHLIGHT_BG = (40, 90, 170, 255)
TITLE = (255, 214, 120, 255)
CLEAR = (0.18, 0.2, 0.24)  # behind the panel when no scene is shown


@dataclass(frozen=True)
class PanelImage:
    """The RGBA image ``(H, W, 4)`` and, per source line, the pixel rows ``(y0, y1)`` it occupies."""

    image: np.ndarray
    rows: tuple[tuple[int, int], ...]


def panel_image(
    lines: tuple[str, ...] | list[str],
    *,
    highlight: int | None = None,
    title_rows: int = 1,
    width_px: int = 900,
    font_size: int = 24,
    padding: int = 18,
) -> PanelImage:
    """Lines wrapped to ``width_px``; ``highlight`` (a source line) on a blue band; the title in amber."""
    font = _font(font_size)
    line_h = int(round(font_size * 1.35))
    probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
    avg = max(probe.textlength("abcdefghij klmnopqrstuvwxyz", font=font) / 27.0, 1.0)
    cols = max(int((width_px - 2 * padding) / avg), 10)
    wrapped: list[list[str]] = [textwrap.wrap(s, cols) or [""] for s in lines]
    h = padding * 2 + line_h * sum(len(w) for w in wrapped)
    img = Image.new("RGBA", (width_px, max(h, 1)), BACKGROUND)
    draw = ImageDraw.Draw(img)
    y = padding
    rows = []
    for k, parts in enumerate(wrapped):
        y0 = y
        if k == highlight:
            draw.rectangle(
                (padding // 2, y0, width_px - padding // 2, y0 + line_h * len(parts)), fill=HIGHLIGHT_BG
            )
        for part in parts:
            draw.text((padding, y), part, font=font, fill=TITLE if k < title_rows else FOREGROUND)
            y += line_h
        rows.append((y0, y))
    return PanelImage(np.asarray(img, dtype=np.uint8), tuple(rows))


def panel_rect(
    size: tuple[int, int], viewport: tuple[int, int, int, int], *, fraction: float = 0.7
) -> tuple[int, int, int, int]:
    """Where a ``size`` (w, h) panel lands in ``viewport``: ``(x, y_top, w, h)`` in viewport pixels from its
    top-left, scaled to ``fraction`` of the viewport's width (or less, to fit the height), centred."""
    w, h = size
    vw, vh = viewport[2], viewport[3]
    s = min(fraction * vw / w, 0.9 * vh / h)
    pw, ph = max(int(w * s), 1), max(int(h * s), 1)
    return (vw - pw) // 2, (vh - ph) // 2, pw, ph


PANEL_DISTANCE = 1.3  # m in front of the eyes, where a world-fixed panel is put
PANEL_WIDTH = 1.0  # m: about 42 degrees of view at that distance


@dataclass(frozen=True)
class PanelAnchor:
    """Where a world-fixed panel stands: its ``center``, unit ``right`` and ``up`` (3D, Y up), and
    ``width`` (m); its height follows the image."""

    center: np.ndarray
    right: np.ndarray
    up: np.ndarray
    width: float = PANEL_WIDTH

    @classmethod
    def facing(cls, view: np.ndarray, eye_position: np.ndarray, *, distance: float = PANEL_DISTANCE,
               width: float = PANEL_WIDTH) -> PanelAnchor:
        """Upright, ``distance`` ahead of an eye (``view`` its 4×4 world-to-eye matrix) at the eye's
        height, facing it: where the head looks when a page appears, but level, so a page shown
        while looking at the floor is not put in the floor."""
        right = np.asarray(view, np.float64)[0, :3].copy()  # the eye's +X: right on the screen
        right[1] = 0.0
        n = float(np.linalg.norm(right))
        right = right / n if n > 1e-6 else np.array([1.0, 0.0, 0.0])  # rolled on its side: any way
        up = np.array([0.0, 1.0, 0.0])
        forward = np.cross(up, right)
        centre = np.asarray(eye_position, np.float64) + distance * forward
        return cls(center=centre, right=right, up=up, width=width)


class PanelDrawer:
    """Draws a :class:`PanelImage` over a framebuffer's viewport (see :func:`panel_rect`)."""

    def __init__(self, ctx: moderngl.Context, *, shader_dir: Path = SHADER_DIR) -> None:
        self.ctx = ctx
        self.prog = compile_program(ctx, "panel.glsl", shader_dir=shader_dir)
        strip = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], dtype=np.float32)
        self.vbo = ctx.buffer(strip.tobytes())
        self.vao = ctx.vertex_array(self.prog, [(self.vbo, "2f", "in_corner")])
        self.tex: moderngl.Texture | None = None

    def clear(self, framebuffer: moderngl.Framebuffer, viewport: tuple[int, int, int, int]) -> None:
        framebuffer.use()
        framebuffer.viewport = viewport
        self.ctx.scissor = viewport
        framebuffer.clear(*CLEAR, 1.0, depth=1.0)
        self.ctx.scissor = None

    def _upload(self, panel: PanelImage) -> tuple[int, int]:
        img = panel.image
        h, w = img.shape[:2]
        if self.tex is None or self.tex.size != (w, h):
            if self.tex is not None:
                self.tex.release()
            self.tex = self.ctx.texture((w, h), 4)
            self.tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.tex.write(np.ascontiguousarray(img).tobytes())
        return w, h

    def _render(self, linear_target: bool) -> None:
        set_uniform(self.prog, "u_tex", 0)
        set_uniform(self.prog, "u_linear_target", linear_target)
        assert self.tex is not None
        self.tex.use(location=0)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self.vao.render(moderngl.TRIANGLE_STRIP, vertices=4)
        self.ctx.disable(moderngl.BLEND)

    def draw_world(
        self,
        panel: PanelImage,
        anchor: PanelAnchor,
        *,
        view_projection: np.ndarray,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        linear_target: bool = False,
    ) -> None:
        """Draw the panel as a quad fixed in the world at ``anchor``, seen through one eye's
        ``view_projection`` (4×4, world to clip), on top of the scene."""
        w, h = self._upload(panel)
        framebuffer.use()
        framebuffer.viewport = viewport
        half_w = 0.5 * anchor.width
        half_h = half_w * h / w
        set_uniform(self.prog, "u_world", True)
        set_uniform(self.prog, "u_view_proj", tuple(np.asarray(view_projection, np.float64).T.ravel()))
        set_uniform(self.prog, "u_center", tuple(anchor.center))
        set_uniform(self.prog, "u_half_right", tuple(half_w * anchor.right))
        set_uniform(self.prog, "u_half_up", tuple(half_h * anchor.up))
        self._render(linear_target)

    def draw(
        self,
        panel: PanelImage,
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int],
        linear_target: bool = False,
        fraction: float = 0.7,
    ) -> tuple[int, int, int, int]:
        """Draw; return the panel's rectangle ``(x, y_top, w, h)`` in viewport pixels (for mouse picking).

        ``linear_target``: the framebuffer encodes linear values to sRGB itself (an sRGB swapchain).
        """
        w, h = self._upload(panel)
        x, y, pw, ph = panel_rect((w, h), viewport, fraction=fraction)
        vw, vh = viewport[2], viewport[3]
        framebuffer.use()
        framebuffer.viewport = viewport
        set_uniform(self.prog, "u_rect", (
            2 * x / vw - 1,
            1 - 2 * (y + ph) / vh,
            2 * (x + pw) / vw - 1,
            1 - 2 * y / vh,
        ))
        set_uniform(self.prog, "u_world", False)
        self._render(linear_target)
        return x, y, pw, ph

    def release(self) -> None:
        if self.tex is not None:
            self.tex.release()
        self.vao.release()
        self.vbo.release()
        self.prog.release()


def row_at(panel: PanelImage, rect: tuple[int, int, int, int], x: float, y: float) -> int | None:
    """The source line under viewport pixel ``(x, y)`` (from the top-left), or None off the panel."""
    px, py, pw, ph = rect
    if not (px <= x < px + pw and py <= y < py + ph):
        return None
    iy = (y - py) * panel.image.shape[0] / ph
    for k, (y0, y1) in enumerate(panel.rows):
        if y0 <= iy < y1:
            return k
    return None
