"""The body layer's kernels compiled in a second process while a first run sets up (issue 27 goal 2).

On a fresh install numba compiles every kernel a step uses the first time it runs. About half of
that time is the body layer's (the pose graph, the gait, the subconscious actions: 52 of 95 s of
compiling for the default scene, load average 4), and none of it depends on the scene: so while
this process builds the scene (compiling the world's kernels) and steps the crowd (the
steering's), a second Python process drives a small crowd of full bodies through the calls a
step makes (:func:`body_kernels`) and numba writes what it compiles to its cache, where this
process's first step finds it. The first step waits for the second process before the body is
first posed (:func:`pedvr.prepare.first_step`), so nothing is compiled twice; if that process
fails, this one compiles as before.

Only a cold cache starts it (:func:`cold`: the pose graph's and the gait's kernels are not in
numba's cache); a warm run starts nothing. ``python -m pedvr.warmup`` is the second process.
"""

from __future__ import annotations

import atexit
import subprocess
import sys
import time

import numpy as np

DT = 1.0 / 90.0
STEPS = 4  # the third crosses the 30 Hz subconscious-action tick


def body_kernels() -> int:
    """Step a user and three agents' full bodies through what :meth:`pedvr.sim.Simulation.step`
    asks of the body (gaze rule, limits, root motion, gait, actions, pose graph, skate meter, the
    sync phase's commit of the roots) and the renderer's bone matrices, with the simulation's array
    types, so numba compiles (or loads) each body kernel a step uses. Returns the number of kernel
    calls' steps made."""
    from pedvr.body import FullBody
    from pedvr.body.simple import sync_kernel
    from pedvr.crowd.state import N_LIMITS, CrowdState

    rng = np.random.default_rng(0)
    body = FullBody(rng=rng)
    crowd = CrowdState.empty()
    limits = np.asarray([1.5, 3.0, 6.0, 3.0, 0.6, 0.6], np.float64)
    for k, (x, y, user) in enumerate(((0.0, 0.0, True), (40.0, 0.0, False), (41.0, 1.0, False),
                                      (40.0, 2.0, False))):
        rows = CrowdState(
            ids=np.asarray([k], np.int64), pos=np.asarray([[x, y]], np.float64), vel=np.zeros((1, 2)),
            pref_vel=np.zeros((1, 2)), heading=np.zeros(1), pref_heading=np.zeros(1), radius=np.full(1, 0.25),
            pref_speed=np.full(1, 1.3), max_speed=np.full(1, 1.6), responsibility=np.full(1, 1.0),
            is_user=np.full(1, user), limits=np.tile(np.zeros(N_LIMITS) if user else limits, (1, 1)))
        rows.pref_speed *= body.append(1, ids=rows.ids, pos=rows.pos, heading=rows.heading, is_user=user,
                                       limits=rows.limits)
        crowd.append(rows)
    names = np.asarray(("walk", "walk", "walk", "walk"))
    vel = np.asarray([[1.2, 0.0], [1.0, 0.2], [0.0, 0.0], [-1.3, 0.1]])
    for step in range(STEPS):
        t = step * DT
        # far from the user: the gaze rule's kernel runs, the visibility query (the world's) does not
        body.gaze_rule(crowd, t=t, visibility=None, d1=4.0, d2=3.0, enabled=True)
        body.fill_limits(crowd, crowd.limits)
        root, heading = body.animate(crowd, vel.copy(), DT, coupled=True)
        body.state.shoulder_turn[:] = np.where(crowd.is_user, 0.0, 0.0 * heading)
        body.compose(crowd, root, heading, dt=DT, t=t + DT, coupled=True, state_names=names)
        pos, new_vel = np.empty((len(crowd), 2)), np.empty((len(crowd), 2))  # the sync phase's commit
        sync_kernel(np.ascontiguousarray(root, np.float64), crowd.pos, crowd.vel, crowd.max_speed,
                    crowd.is_user, DT, pos, new_vel)
        crowd.pos = np.where(crowd.is_user[:, None], crowd.pos, root)
        crowd.vel = vel.copy()
        crowd.heading = heading
    body.joint_matrices()
    return STEPS


def _body_dispatchers() -> list[object]:
    from pedvr.body import graph, locomotion

    return [graph._pose_rows, locomotion.gait_kernel]


def cold() -> bool:
    """Whether numba's cache lacks the body's two largest kernels (then a first step compiles for
    minutes). Reads numba's cache index (a private API: if it changes, the answer is False and
    nothing is started)."""
    try:
        for disp in _body_dispatchers():
            if not disp._cache._cache_file._load_index():  # type: ignore[attr-defined]
                return True
    except Exception:  # noqa: BLE001 - numba's internals moved: behave as without this module
        return False
    return False


class Warmer:
    """``python -m pedvr.warmup`` running beside this process (see the module doc)."""

    def __init__(self) -> None:
        self.started = time.perf_counter()
        self.proc: subprocess.Popen[bytes] | None = subprocess.Popen(
            [sys.executable, "-m", "pedvr.warmup"], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        self.ok: bool | None = None
        self.waited_s = 0.0
        atexit.register(self.stop)  # a run that fails before its first step leaves no process behind

    def wait(self) -> bool:
        """Block until the second process is done; True when it compiled everything it meant to."""
        if self.proc is not None:
            t0 = time.perf_counter()
            self.ok = self.proc.wait() == 0
            self.waited_s = time.perf_counter() - t0
            self.proc = None
        return bool(self.ok)

    def stop(self) -> None:
        """End the second process if it still runs (a run interrupted while preparing)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.proc = None


started: Warmer | None = None


def start_if_cold() -> Warmer | None:
    """Start the second process when the cache is cold (once per process); the one started."""
    global started
    if started is None and cold():
        started = Warmer()
    return started


def take() -> Warmer | None:
    """The started second process, handed to the one first step that waits for it."""
    global started
    w, started = started, None
    return w


if __name__ == "__main__":
    body_kernels()
