"""Looks on rendered pixels (issue 25): clean crosswalk paint. Offscreen EGL renders; properties,
not golden images."""

from __future__ import annotations

import math

import moderngl
import numpy as np
from skimage.color import rgb2lab

from pedvr.render.math3d import EyeView, first_person_eye
from pedvr.render.renderer import OffscreenTarget, Renderer
from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene

# -- crosswalk paint (item 17) --------------------------------------------------------------------------


def _ground_points(eye: EyeView, width: int, height: int, y: float) -> np.ndarray:
    """World points ``(height, width, 3)`` where each pixel's centre ray meets the plane at height ``y``."""
    inv = np.linalg.inv(eye.view_projection)
    cols, rows = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
    ndc = np.stack([cols / width * 2 - 1, 1 - rows / height * 2], axis=-1)
    near = np.concatenate([ndc, -np.ones(ndc.shape[:2] + (1,)), np.ones(ndc.shape[:2] + (1,))], -1) @ inv.T
    far = np.concatenate([ndc, np.ones(ndc.shape[:2] + (2,))], -1) @ inv.T
    a, b = near[..., :3] / near[..., 3:], far[..., :3] / far[..., 3:]
    t = (y - a[..., 1]) / (b[..., 1] - a[..., 1])
    return a + (b - a) * t[..., None]


STRIPE_VIEW = (640, 360)


def crosswalk_view(ctx: moderngl.Context) -> tuple[np.ndarray, np.ndarray]:
    """shibuya_crossing's south crosswalk (from (-4.2, -5.6) to (4.2, -5.6), 3 m wide, bars 0.5 m
    deep every metre) in the sun, seen by a participant standing 4.5 m before it, at a 1280×720
    frame's pixel density: the image and the mask of pixels well inside the bars."""
    config = load_scene(resolve_scene("shibuya_crossing"))
    mk = config.world.markings[0]
    assert mk.start == (-4.2, -5.6) and mk.end == (4.2, -5.6) and mk.width == 3.0
    w, h = STRIPE_VIEW
    fovy = 2.0 * math.atan(h / 2 / (720 / 2 / math.tan(math.radians(35.0))))
    eye = first_person_eye(pos=np.array([0.3, -11.6]), heading=math.pi / 2, pitch=-0.35, eye_height=1.65,
                           fovy=fovy, aspect=w / h)
    r = Renderer(ctx, world=config.world)
    t = OffscreenTarget(ctx, (w, h))
    r.begin_frame()
    r.update(Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0)))
    r.draw_scene([eye], framebuffer=t.fbo)
    img = t.read()
    t.release()
    r.release()
    g = _ground_points(eye, w, h, 0.006)
    along, across = g[..., 0] - mk.start[0], g[..., 2] - mk.start[1]
    inside = ((np.abs(across) < mk.width / 2 - 0.15) & (along > 0.5) & (along < 8.0)
              & (np.mod(along, 1.0) > 0.6) & (np.mod(along, 1.0) < 0.9))
    assert inside.sum() > 2000
    return img, inside


def crosswalk_stripes(ctx: moderngl.Context) -> np.ndarray:
    """L* of the pixels well inside the bars (:func:`crosswalk_view`)."""
    img, inside = crosswalk_view(ctx)
    return rgb2lab(img.astype(np.float64) / 255.0)[..., 0][inside]


def test_crosswalk_bars_are_paint_without_dark_blotches(ctx: moderngl.Context) -> None:
    """Issue 25 item 17: the bars were full of dark blotches. Their cause was the paint's wear, made
    by discarding the bar's fragments wherever a noise fell below a threshold, which punched holes
    to the asphalt (not shadow acne: the floor is not in the shadow map; not z-fighting: the
    markings lie 6 mm above the floor). Inside the sunlit bars no pixel is much darker than the
    paint (ΔL* 20 below the median), and the paint's lightness varies little (σ < 4 L*)."""
    L = crosswalk_stripes(ctx)
    dark = L < np.median(L) - 20.0
    assert dark.mean() < 0.001, f"{dark.mean():.2%} of the bars' pixels are dark blotches"
    assert L.std() < 4.0, L.std()
