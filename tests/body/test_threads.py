"""Bodies (and the crowd beneath them) come out bit-identical whatever the number of numba threads
(issue 12): a plaza on 1 thread against the same plaza with every kernel on its parallel twin, 2 threads."""

from __future__ import annotations

import contextlib
import hashlib

import numba
import pytest

from pedvr.bench_sim import plaza_scene
from pedvr.kernels import forcing
from pedvr.sim import Simulation


def _digest(threads: int) -> str:
    """With more than one thread every kernel is pinned to its parallel twin: a 600-agent plaza fits
    the serial budget (pedvr.kernels.SERIAL_BUDGET_S), and left alone would run on one thread."""
    numba.set_num_threads(threads)
    with forcing(True) if threads > 1 else contextlib.nullcontext():
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


def test_pose_graph_twins_give_the_same_bytes() -> None:
    """The pose graph's serial loop and its parallel chunks pose every body identically."""

    def digest(parallel: bool) -> str:
        with forcing(parallel):
            sim = Simulation(plaza_scene(300, seed=7), condition="pedvr+g", record=False)
            for _ in range(30):
                sim.step()
        b = sim.body.state
        h = hashlib.sha256()
        for a in (b.world_pos, b.world_q, b.local_q, b.gaze_ang, b.h_prev, b.foot_pitch):
            h.update(a.tobytes())
        return h.hexdigest()

    assert digest(True) == digest(False)


_CHILD = """
import hashlib, sys
import numba
from pedvr.bench_sim import plaza_scene
from pedvr.kernels import forcing
from pedvr.sim import Simulation
with forcing(numba.get_num_threads() > 1):  # on 2 threads every kernel takes its parallel twin
    sim = Simulation(plaza_scene(300, seed=11), condition="pedvr+g", record=True)
    for _ in range(40):
        sim.step()
b = sim.body.state
h = hashlib.sha256()
for a in (b.world_pos, b.world_q, b.local_q, b.foot_ref, b.gaze_ang, sim.crowd.pos, sim.crowd.vel):
    h.update(a.tobytes())
print(numba.get_num_threads(), h.hexdigest())
"""


def test_same_bytes_with_numba_num_threads_1_and_2() -> None:
    """Issue 27 goal 3, as a user sets it: two processes started with ``NUMBA_NUM_THREADS=1`` and
    ``=2`` (numba's thread pool sized at start, not changed afterwards) step the same plaza to the
    same bytes, the two-thread one with every parallel kernel on its parallel twin."""
    import os
    import subprocess
    import sys

    out = {}
    for threads in ("1", "2"):
        env = {**os.environ, "NUMBA_NUM_THREADS": threads}
        res = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True,
                             timeout=900, check=False)
        assert res.returncode == 0, res.stderr[-2000:]
        n, digest = res.stdout.split()
        assert n == threads  # the pool really had that many threads
        out[threads] = digest
    assert out["1"] == out["2"]
