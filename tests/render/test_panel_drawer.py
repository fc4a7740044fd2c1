"""The study's panel drawer uses ``shaders/panel.glsl`` and writes the image's sRGB values as they
are, or decoded to linear for a target that encodes to sRGB itself (an sRGB XR swapchain)."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from pedvr.render.panel import PanelDrawer, PanelImage
from pedvr.render.renderer import OffscreenTarget


@pytest.mark.parametrize("linear_target", [False, True])
def test_panel_pixels_are_the_image_or_its_linear_values(ctx: moderngl.Context, linear_target: bool) -> None:
    img = np.zeros((20, 40, 4), np.uint8)
    img[..., :3] = (200, 120, 40)
    img[..., 3] = 255
    drawer = PanelDrawer(ctx)
    t = OffscreenTarget(ctx, (80, 60))
    drawer.clear(t.fbo, (0, 0, 80, 60))
    x, y, w, h = drawer.draw(PanelImage(img, ((0, 20),)), framebuffer=t.fbo, viewport=(0, 0, 80, 60),
                             linear_target=linear_target, fraction=0.5)
    px = t.read().astype(float)[y + h // 2, x + w // 2]
    want = np.array([200.0, 120.0, 40.0])
    if linear_target:
        want = 255.0 * (want / 255.0) ** 2.2
    np.testing.assert_allclose(px, want, atol=2.0)
    t.release()
    drawer.release()
