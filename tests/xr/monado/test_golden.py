"""Golden eye views from Monado's real compositor, read back from the swapchains (issue 23).

Monado runs its real compositor on Xvfb (``XRT_COMPOSITOR_FORCE_XCB``; 896x1007
per eye on lavapipe) with the qwerty HMD, which stands still at 1.6 m until a
key moves it, so the first drawn frame is the same every time: the scene after
its first step (the frame loop's clock starts at the first drawn frame) seen
from the scene's start. pedvr saves that frame's two eyes as the runtime received them
(``PEDVR_XR_CAPTURE``). The references are those eyes reduced 8x (box filter),
``golden/<scene>-seed<seed>-eye<k>-112x125-monado-llvmpipe.png``, compared as in
tests/render/test_golden.py (diff images on failure); regenerate with
``PEDVR_REGENERATE_GOLDEN=1``.

The same captures decide the yaw convention (issue 23 item 1): the left eye must
show what the headless first-person camera at the scene's heading shows, and
not what it shows turned by 90° either way or 180°.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pedvr.render.math3d import EyeView, first_person_rotation, ground_to_world, projection_from_fov
from pedvr.render.renderer import OffscreenTarget, Renderer, create_offscreen_context
from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation
from tests.xr.monado.chroot import Chroot, Service, Xvfb
from tests.xr.monado.conftest import Workspace

GOLDEN = Path(__file__).parent / "golden"
SCENES = ("antipodal_circle", "corridor_passing", "shibuya_crossing")
REDUCE = 8


@pytest.fixture(scope="module")
def captures(chroot: Chroot, xvfb: Xvfb) -> Iterator[dict[str, Path]]:
    """Each scene's first drawn frame, both eyes, from one qwerty service on the real compositor."""
    work = Workspace(chroot, "golden")
    svc = Service(chroot, log=work.host / "monado.log", devices="qwerty", compositor="xcb",
                  display=xvfb.display)
    out: dict[str, Path] = {}
    try:
        for scene in SCENES:
            cap = f"{work.path}/{scene}-eyes"
            run = work.pedvr(svc, ["run", scene, "--backend", "xr", "--duration", "0.3"], name=scene,
                             PEDVR_XR_CAPTURE=cap, DISPLAY=xvfb.display)
            assert run.proc.returncode == 0, run.proc.stderr
            out[scene] = chroot.host(cap)
    finally:
        svc.stop()
    yield out


def _reduce(img: np.ndarray) -> np.ndarray:
    h, w = (img.shape[0] // REDUCE) * REDUCE, (img.shape[1] // REDUCE) * REDUCE
    a = img[:h, :w].astype(np.float64).reshape(h // REDUCE, REDUCE, w // REDUCE, REDUCE, 3)
    return np.round(a.mean(axis=(1, 3))).astype(np.uint8)


def _eye(cap: Path, k: int) -> np.ndarray:
    return np.asarray(Image.open(cap / f"eye{k}.png").convert("RGB"))


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("eye", [0, 1])
def test_golden_eye_view(captures: dict[str, Path], scene: str, eye: int, tmp_path: Path) -> None:
    img = _reduce(_eye(captures[scene], eye))
    seed = load_scene(resolve_scene(scene)).seed
    name = f"{scene}-seed{seed}-eye{eye}-{img.shape[1]}x{img.shape[0]}-monado-llvmpipe.png"
    _compare(img, GOLDEN / name, f"{scene}-eye{eye}", tmp_path)


def test_both_eyes_see_the_scene_in_stereo(captures: dict[str, Path]) -> None:
    left, right = (_eye(captures["corridor_passing"], k).astype(int) for k in (0, 1))
    assert left.shape == right.shape == (1007, 896, 3)
    assert left.std() > 10 and np.abs(left - right).mean() > 0.5  # not blank, not the same picture
    views = json.loads((captures["corridor_passing"] / "views.json").read_text())
    ipd = views[1]["position"][0] - views[0]["position"][0]
    assert 0.05 < ipd < 0.08  # the left eye is on the left


@pytest.mark.parametrize("scene", SCENES)
def test_the_first_eye_view_faces_the_scenes_heading(captures: dict[str, Path], scene: str) -> None:
    """Issue 23 item 1: the headset started 90° left of the scene's heading (facing a wall)."""
    cap = captures[scene]
    view = json.loads((cap / "views.json").read_text())[0]
    config = load_scene(resolve_scene(scene))
    sim = Simulation(config)
    sim.step()  # as the first drawn frame: the world after its first step (bodies posed)
    snap = Snapshot.from_sim(sim)
    w, h = (s // REDUCE for s in view["size"])
    ctx = create_offscreen_context()
    renderer = Renderer.for_scene(ctx, config)
    target = OffscreenTarget(ctx, (w, h))
    renderer.hide_user = True
    renderer.update(snap)
    left, right, up, down = view["fov"]
    proj = projection_from_fov(angle_left=left, angle_right=right, angle_up=up, angle_down=down)
    position = ground_to_world(np.asarray(config.user.start), view["position"][1])
    seen = _reduce(_eye(cap, 0)).astype(float)
    diffs = {}
    try:
        for turn in (0, 90, -90, 180):
            eye = EyeView.from_pose(rotation=first_person_rotation(config.user.heading + math.radians(turn)),
                                    position=position, projection=proj)
            renderer.draw_scene([eye], framebuffer=target.fbo, viewport=(0, 0, w, h))
            drawn = target.read().astype(float)[: seen.shape[0], : seen.shape[1]]
            diffs[turn] = float(np.abs(drawn - seen).mean())
    finally:
        target.release()
        renderer.release()
        ctx.release()
    others = min(v for k, v in diffs.items() if k != 0)
    assert diffs[0] < 0.5 * others, f"{scene}: mean colour difference by headless turn (deg): {diffs}"


def _compare(img: np.ndarray, ref_path: Path, name: str, tmp_path: Path) -> None:
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
        Image.fromarray(img).save(tmp_path / f"{name}-actual.png")
        Image.fromarray(np.clip(diff * 4, 0, 255).astype(np.uint8)).save(tmp_path / f"{name}-diff.png")
        pytest.fail(
            f"{name}: {bad.mean():.2%} of pixels differ (mean {diff.mean():.2f}) from {ref_path}; "
            f"see {tmp_path}/{name}-actual.png and -diff.png; regenerate with PEDVR_REGENERATE_GOLDEN=1"
        )
