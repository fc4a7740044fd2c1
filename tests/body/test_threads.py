"""Bodies (and the crowd beneath them) come out bit-identical whatever the number of numba threads
(issue 12): a plaza large enough that the crowd kernels take their parallel path, with 1 and 2 threads."""

from __future__ import annotations

import hashlib

import numba
import pytest

from pedvr.bench_sim import plaza_scene
from pedvr.sim import Simulation


def _digest(threads: int) -> str:
    numba.set_num_threads(threads)
    sim = Simulation(plaza_scene(600, seed=5), condition="pedvr+g", record=True)
    for _ in range(45):
        sim.step()
    b = sim.body.state
    h = hashlib.sha256()
    for a in (b.world_pos, b.world_q, b.local_q, b.foot_ref, b.gaze_ang, sim.crowd.pos, sim.crowd.vel):
        h.update(a.tobytes())
    h.update(sim.body.skate.slides().tobytes())
    return h.hexdigest()


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs numba with 2 threads or more")
def test_same_bytes_with_one_and_two_threads() -> None:
    before = numba.get_num_threads()
    try:
        assert _digest(1) == _digest(2)
    finally:
        numba.set_num_threads(before)
