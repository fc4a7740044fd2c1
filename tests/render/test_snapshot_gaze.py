"""The overhead view's gaze lines come from the body's attention (PedVR Fig. 4)."""

from __future__ import annotations

import numpy as np

from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _first_gaze(condition: str) -> tuple[Snapshot | None, Simulation]:
    sim = Simulation(load_scene(resolve_scene("headon_corridor")), condition=condition)
    for _ in range(round(6.0 / sim.dt)):
        sim.step()
        snap = Snapshot.from_sim(sim)
        assert snap.gaze_target is not None
        if np.isfinite(snap.gaze_target).all(axis=1).any():
            return snap, sim
    return None, sim


def test_gaze_rule_shows_a_line_to_the_user_head() -> None:
    snap, sim = _first_gaze("pedvr+g")
    assert snap is not None, "the approaching agent never gazed at the user"
    agent = ~snap.is_user
    assert np.isfinite(snap.gaze_target[agent]).all()  # type: ignore[index]
    assert np.isnan(snap.gaze_target[snap.is_user]).all()  # type: ignore[index]
    # the line ends at the user (the user's head, above the user's floor position)
    user_xz = snap.pos[snap.is_user][0]
    assert np.linalg.norm(snap.gaze_target[agent][0, [0, 2]] - user_xz) < 0.3  # type: ignore[index]
    assert 1.4 < snap.gaze_target[agent][0, 1] < 2.0  # type: ignore[index]


def test_no_gaze_lines_without_the_rule() -> None:
    snap, _ = _first_gaze("pedvr")
    assert snap is None
