"""Golden images, only on Mesa llvmpipe (STYLE.md habit 9: tiny, renderer-named, regenerate flag, diffs).

Regenerate with ``PEDVR_REGENERATE_GOLDEN=1 pytest tests/render/test_golden.py``. References live in
``tests/render/golden/<scene>-seed<seed>-<camera>-<w>x<h>-llvmpipe.png``; on failure the rendered
image and an amplified difference are written next to the test's tmp_path and named in the message.
Every shipped scene's first-person view is here too (half a second into the run, from the user's
eyes); what regenerating cannot fake is checked as properties in test_render.py and
test_characters.py.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import moderngl
import numpy as np
import pytest
from PIL import Image

from pedvr.render.environment import exhibit_shapes
from pedvr.render.math3d import desktop_stereo_eyes, first_person_eye
from pedvr.render.renderer import OffscreenTarget, Renderer, gl_renderer_name
from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene, shipped_scenes
from pedvr.sim import Simulation
from tests.render.conftest import WORLD, posed

GOLDEN = Path(__file__).parent / "golden"
W, H = 64, 48


def _snapshot() -> Snapshot:
    """Three bodies from the body layer: two walking (one toward the camera), one standing gazing at it."""
    snap, _ = posed(
        [[3.7, 0.4], [4.0, -0.8], [5.4, 1.8]],
        [math.pi, 2.5, -2.0],
        vel=[[-1.2, 0.0], [0.0, 0.0], [-0.45, -0.9]],
        seconds=1.0,
        gaze={0: (0.0, 1.6, 0.0), 1: (0.0, 1.6, 0.0)},
        sphere=np.array([5.0, 0.0]),
    )
    gaze = np.array([[0.0, 1.6, 0.0], [0.0, 1.6, 0.0], [np.nan] * 3])
    return dataclasses.replace(snap, gaze_target=gaze)


CAMERAS = {
    "first_person": lambda: [first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)],
    "stereo": lambda: list(
        desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=(W / 2) / H)
    ),
}


@pytest.mark.parametrize("camera", sorted(CAMERAS) + ["overhead"])
def test_golden_image(ctx: moderngl.Context, camera: str, tmp_path: Path) -> None:
    name = gl_renderer_name(ctx)
    if "llvmpipe" not in name:
        pytest.skip(f"golden images are for Mesa llvmpipe only; this is {name}")
    r = Renderer(ctx, world=WORLD)
    t = OffscreenTarget(ctx, (W, H))
    r.update(_snapshot())
    if camera == "overhead":
        r.draw_overhead(framebuffer=t.fbo)
    else:
        r.draw_scene(CAMERAS[camera](), framebuffer=t.fbo)
    img = t.read()
    t.release()
    r.release()
    _compare(img, GOLDEN / f"test_world-seed0-{camera}-{W}x{H}-llvmpipe.png", camera, tmp_path)


SW, SH = 96, 54  # the scenes' first-person views


@pytest.mark.parametrize("scene", [p.stem for p in shipped_scenes()])
def test_golden_scene_first_person(ctx: moderngl.Context, scene: str, tmp_path: Path) -> None:
    name = gl_renderer_name(ctx)
    if "llvmpipe" not in name:
        pytest.skip(f"golden images are for Mesa llvmpipe only; this is {name}")
    config = load_scene(resolve_scene(scene))
    sim = Simulation(config)
    for _ in range(round(0.5 / sim.dt)):
        sim.step()
    snap = Snapshot.from_sim(sim)
    u = snap.user_row
    assert u is not None
    eye = first_person_eye(pos=snap.pos[u], heading=float(snap.heading[u]), aspect=SW / SH)
    r = Renderer(ctx, world=config.world, shadow_map_size=1024,
                 exhibits=exhibit_shapes(config.world, config.behavior.objects))
    t = OffscreenTarget(ctx, (SW, SH))
    r.update(snap)
    r.draw_scene([eye], framebuffer=t.fbo)
    img = t.read()
    t.release()
    r.release()
    _compare(img, GOLDEN / f"{scene}-seed{config.seed}-first_person-{SW}x{SH}-llvmpipe.png", scene, tmp_path)


def _compare(img: np.ndarray, ref_path: Path, camera: str, tmp_path: Path) -> None:
    if os.environ.get("PEDVR_REGENERATE_GOLDEN") == "1" or not ref_path.exists():
        if os.environ.get("PEDVR_REGENERATE_GOLDEN") != "1":
            pytest.fail(f"{ref_path} is missing; run with PEDVR_REGENERATE_GOLDEN=1 to create it")
        GOLDEN.mkdir(exist_ok=True)
        Image.fromarray(img).save(ref_path)
        return
    ref = np.asarray(Image.open(ref_path).convert("RGB")).astype(int)
    diff = np.abs(img.astype(int) - ref)
    bad = diff.max(axis=2) > 24
    if bad.mean() > 0.005 or diff.mean() > 1.5:
        Image.fromarray(img).save(tmp_path / f"{camera}-actual.png")
        Image.fromarray(np.clip(diff * 4, 0, 255).astype(np.uint8)).save(tmp_path / f"{camera}-diff.png")
        pytest.fail(
            f"{camera}: {bad.mean():.2%} of pixels differ (mean {diff.mean():.2f}) from {ref_path}; "
            f"see {tmp_path}/{camera}-actual.png and -diff.png; regenerate with PEDVR_REGENERATE_GOLDEN=1"
        )
