"""Bodies are posed from t = 0: a frame drawn before the first step (a headless video's first frame)
showed every joint at the origin, an empty scene with a dark blob where the bodies had collapsed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pedvr.body import quat
from pedvr.body import skeleton as sk
from pedvr.scene.loader import load_any
from pedvr.scenes import shipped_scenes
from pedvr.sim import Simulation


@pytest.mark.parametrize("path", list(shipped_scenes()), ids=lambda p: p.stem)
def test_every_body_stands_where_it_spawned_before_the_first_step(path: Path) -> None:
    sim = Simulation(load_any(path, seed=None))
    b, c = sim.body.state, sim.crowd
    assert sim.step_index == 0 and len(b) == len(c)
    if len(c) == 0:
        return
    wp = b.world_pos
    seated = b.sitting
    head = wp[:, sk.HEAD, 1]
    scale = b.dims[:, sk.DIM_SCALE]
    assert np.all(head[~seated] > 1.25 * scale[~seated]), head  # standing, not collapsed
    assert np.all(head[seated] > 0.8 * scale[seated]), head
    heels = wp[:, [sk.L_HEEL, sk.R_HEEL], 1]
    assert np.all(np.abs(heels[~seated]) < 0.08), heels  # feet on the floor
    root = quat.ground_to_3d(c.pos)
    assert np.all(np.linalg.norm((wp[:, sk.PELVIS] - root)[:, [0, 2]], axis=1) < 0.15)  # over the agent's own spot

