"""Parallel kernels and their serial twins give the same bytes."""

from __future__ import annotations

import numpy as np
import pytest

from pedvr.crowd import orca
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.crowd.steering import Steering
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet


def crowd(n: int, seed: int) -> CrowdState:
    rng = np.random.default_rng(seed)
    side = np.sqrt(n) * 1.2
    g = np.stack(np.meshgrid(np.arange(int(np.ceil(np.sqrt(n)))), np.arange(int(np.ceil(np.sqrt(n))))), -1)
    pos = g.reshape(-1, 2)[:n] * 1.2 - side / 2 + rng.uniform(-0.2, 0.2, (n, 2))
    s = CrowdState.empty()
    s.append(CrowdState(
        ids=np.arange(n), pos=pos, vel=rng.uniform(-1, 1, (n, 2)), pref_vel=rng.uniform(-1.3, 1.3, (n, 2)),
        heading=rng.uniform(-np.pi, np.pi, n), pref_heading=np.zeros(n), radius=np.full(n, 0.25),
        pref_speed=np.full(n, 1.3), max_speed=np.full(n, 1.6), responsibility=np.full(n, 1.0),
        is_user=np.zeros(n, np.bool_), limits=np.tile([1.5, 2.5, 3.0, 1.6, 0.5, 0.6], (n, 1)).reshape(n, N_LIMITS)))
    return s


@pytest.mark.parametrize("coupled", [False, True])
def test_serial_twin_equals_parallel(coupled: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    state = crowd(900, seed=1)
    steer = Steering(SteeringParams(), ObstacleSet.empty(), coupled=coupled)
    assert len(state) >= orca.orca_kernel.min_rows  # the parallel kernel runs
    par = steer.compute_velocities(state, 1 / 90).copy()
    monkeypatch.setattr(orca.orca_kernel, "min_rows", 10**9)
    ser = steer.compute_velocities(state, 1 / 90)
    assert par.tobytes() == ser.tobytes()
