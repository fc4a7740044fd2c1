"""Issue 26, item 3: ``decoupled`` stays the paper's plain-ORCA baseline, and pedvr's own addition,
turned shoulders, must not pack it denser than the discs it steers with. Behind the 1.45 m entrance
of the Jülich corridor its bodies packed to 0.27 m centre to centre (shoulders turned; 3.4 m⁻² in
the measurement area, real 1.5) before decoupled bodies stopped turning."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def test_decoupled_bodies_keep_their_discs_in_a_crowded_entrance() -> None:
    sim = Simulation(load_any(resolve_scene("validation/uo_145"), seed=None), condition="decoupled")
    closest = np.inf
    turned = 0.0
    while sim.t < 40.0:
        sim.step()
        c = sim.crowd
        turned = max(turned, float(c.turn.max(initial=0.0)))
        virt = c.pos[~c.is_user]
        if len(virt) > 1:
            d, _ = cKDTree(virt).query(virt, k=2)
            closest = min(closest, float(d[:, 1].min()))
    radius = float(sim.crowd.radius[~sim.crowd.is_user].min())
    assert turned == 0.0
    assert closest >= 2.0 * radius - 0.01, closest  # discs: no closer than touching, less 1 cm
