"""Doors inside the simulation: the user pushes a door open by walking through it, leaves
reach the renderer's snapshot, and a run with doors is deterministic."""

from __future__ import annotations

import math

import numpy as np

from pedvr.render.snapshot import Snapshot
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.sim import Simulation


def _office() -> Simulation:
    return Simulation(load_any(resolve_scene("office_doors"), seed=None), record=True)


def test_the_user_walking_through_opens_the_single_door() -> None:
    sim = _office()
    assert len(sim.doors) == 3  # a single door and a double door's two leaves
    crossed_at = None
    while sim.t < 8.0 and crossed_at is None:
        before = sim.crowd.pos[0, 0]
        sim.step()
        if before < 0.0 <= sim.crowd.pos[0, 0]:
            crossed_at = abs(float(sim.doors.angle[0]))
    assert crossed_at is not None, "the scripted user did not reach the single door in 8 s"
    assert crossed_at >= math.radians(70)
    assert sim.doors.side[0] == -1  # the single door's + side is -x: it swung east, away from the user
    snap = Snapshot.from_sim(sim)
    assert snap.doors is not None and snap.doors.shape == (3, 5)
    np.testing.assert_allclose(snap.doors[:, 2], sim.doors.base + sim.doors.angle)


def test_same_seed_same_door_motion_and_it_is_recorded() -> None:
    runs = []
    for _ in range(2):
        sim = _office()
        sim.advance_to(10.0)
        arr = sim.recording.arrays()
        # The recording keeps every leaf's angle per step, ending where the doors are now.
        assert arr["door_angle"].shape == (arr["t"].shape[0], 3)
        np.testing.assert_array_equal(arr["door_angle"][-1], sim.doors.angle)
        assert np.abs(arr["door_angle"]).max() > 1.0  # some leaf opened more than 57 degrees
        runs.append((arr["door_angle"].tobytes(), arr["pos"].tobytes()))
    assert runs[0] == runs[1]
