"""The study's panel drawer uses ``shaders/panel.glsl`` and writes the image's sRGB values as they
are, or decoded to linear for a target that encodes to sRGB itself (an sRGB XR swapchain); in the
headset a panel is a quad fixed in the world, seen through each eye."""

from __future__ import annotations

import math

import moderngl
import numpy as np
import pytest

from pedvr.render.math3d import desktop_stereo_eyes, first_person_eye
from pedvr.render.panel import PanelAnchor, PanelDrawer, PanelImage
from pedvr.render.renderer import OffscreenTarget

W, H = 160, 100


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


def _panel() -> PanelImage:
    img = np.zeros((60, 100, 4), np.uint8)
    img[...] = (250, 250, 250, 255)
    return PanelImage(img, ((0, 60),))


def _columns(ctx: moderngl.Context, drawer: PanelDrawer, anchor: PanelAnchor, eye: object) -> np.ndarray:
    t = OffscreenTarget(ctx, (W, H))
    drawer.clear(t.fbo, (0, 0, W, H))
    drawer.draw_world(_panel(), anchor, view_projection=eye.view_projection, framebuffer=t.fbo,  # type: ignore[attr-defined]
                      viewport=(0, 0, W, H))
    img = t.read().astype(int)
    t.release()
    return np.flatnonzero((img.min(axis=2) > 200).any(axis=0))


def test_world_panel_has_stereo_disparity_and_stays_put_when_the_head_turns(ctx: moderngl.Context) -> None:
    drawer = PanelDrawer(ctx)
    left, right = desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    anchor = PanelAnchor.facing(left.view, 0.5 * (left.position + right.position))
    cl, cr = _columns(ctx, drawer, anchor, left), _columns(ctx, drawer, anchor, right)
    assert cl.size > 20 and cr.size > 20
    # A near object sits further right in the left eye's image than in the right eye's.
    assert cl.mean() > cr.mean() + 1.0
    # World-fixed: turn the head 20 degrees to the right and the panel moves left on the screen.
    turned = first_person_eye(pos=np.zeros(2), heading=math.radians(20), eye_height=1.6, aspect=W / H)
    ahead = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    assert _columns(ctx, drawer, anchor, turned).mean() < _columns(ctx, drawer, anchor, ahead).mean() - 20
    drawer.release()
