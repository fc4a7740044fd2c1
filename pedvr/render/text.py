"""Text panels drawn with Pillow into RGBA images, uploaded as textures by the renderer.

The HUD shows frames per second, frame time and the condition *label* only
(A, B, C: the study is blind, PedVR §6.2.4; the condition's name never
appears). Questionnaire pages (the study) use :func:`text_panel` too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from PIL import Image, ImageDraw, ImageFont

from pedvr.errors import UsageError

LABELS = tuple("ABCDEFGH")


def _font(size: int) -> ImageFont.FreeTypeFont | ImageFont.ImageFont:
    # Pillow's bundled scalable font: the same glyphs on every machine (golden images).
    return ImageFont.load_default(size=size)


def text_panel(
    lines: list[str],
    *,
    font_size: int = 18,
    padding: int = 8,
    background: tuple[int, int, int, int] = (0, 0, 0, 150),
    foreground: tuple[int, int, int, int] = (255, 255, 255, 255),
    min_width: int = 0,
) -> np.ndarray:
    """An RGBA ``uint8`` image ``(H, W, 4)`` with ``lines`` of text, top row first."""
    if font_size <= 0:
        raise UsageError(f"font_size {font_size}: must be > 0")
    font = _font(font_size)
    probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))
    widths = [probe.textlength(line, font=font) for line in lines] or [0.0]
    line_h = int(round(font_size * 1.25))
    w = max(int(max(widths)) + 2 * padding, min_width, 1)
    h = max(line_h * len(lines) + 2 * padding, 1)
    img = Image.new("RGBA", (w, h), background)
    draw = ImageDraw.Draw(img)
    for k, line in enumerate(lines):
        draw.text((padding, padding + k * line_h), line, font=font, fill=foreground)
    return np.asarray(img, dtype=np.uint8)


@dataclass
class Hud:
    """The heads-up display's content; ``label`` is the blind condition label (A, B, C) or None."""

    label: str | None = None
    fps: float = 0.0
    frame_ms: float = 0.0

    def __post_init__(self) -> None:
        if self.label is not None and self.label not in LABELS:
            raise UsageError(
                f"HUD label {self.label!r}: expected one of {', '.join(LABELS)} (never a condition name)"
            )

    def lines(self) -> list[str]:
        out = [f"{self.fps:5.1f} fps  {self.frame_ms:5.1f} ms"]
        if self.label is not None:
            out.append(f"condition {self.label}")
        return out

    def image(self, *, font_size: int = 16) -> np.ndarray:
        return text_panel(self.lines(), font_size=font_size)
