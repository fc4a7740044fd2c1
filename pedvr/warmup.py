"""The scene's kernels compiled in a second process while a first run sets up (issue 27 goal 2).

On a fresh install numba compiles every kernel a step uses the first time it runs: minutes on a
small machine. Building a simulation already compiles the largest one, the pose graph's
(:meth:`pedvr.body.model.FullBody.pose_at_rest` poses every body before the first step; 81 of 183 s
of compiling the default scene on this 2-core VM, one process), and the world's. So while this
process builds the scene, a second Python process (``python -m pedvr.warmup SCENE CONDITION``)
builds the same scene and steps it as ``pedvr prepare`` does (:func:`scene_kernels`), with the pose
graph left out, and numba writes what it compiles to its cache: the steering's, the contact pass's,
the doors', the body's other kernels, with the very types this process's step will use. This
process's first step waits for the second before it starts (:func:`pedvr.prepare.first_step`), so
nothing but the world's few kernels is compiled twice; if that process fails, this one compiles as
before.

Until stop 50 the second process posed a small crowd of bodies instead. It compiled the pose graph
too, at the same time as this process's set-up did: each compiled it, and a cold ``pedvr prepare``
took as long as one process would (326 s and 566 CPU-s, against 313 s in one process).

Only a cold cache starts it (:func:`cold`: the pose graph's and the gait's kernels are not in
numba's cache); a warm run starts nothing.
"""

from __future__ import annotations

import atexit
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def _without_pose_graph() -> Iterator[None]:
    """Bodies are not posed inside the block (the pose graph's kernel is not called, so not compiled):
    the other process compiles it as it builds its simulation. Nothing a step steers by reads the
    pose (a coupled body's root comes from its gait, before the pose)."""
    from pedvr.body import model

    kernel = model.pose_graph_kernel
    model.pose_graph_kernel = lambda *args, **kwargs: None  # type: ignore[assignment]
    try:
        yield
    finally:
        model.pose_graph_kernel = kernel


def scene_kernels(scene: str, condition: str = "pedvr+g") -> int:
    """Build ``scene`` (a name or a path) and step it as ``pedvr prepare`` does, the pose graph left
    out (:func:`_without_pose_graph`), so that numba compiles (or loads) each kernel but that one with
    the types a run of the scene uses. Returns the steps made."""
    from pedvr.prepare import PREPARE_STEPS, twin_steps
    from pedvr.scene.loader import load_any
    from pedvr.scenes import resolve_scene
    from pedvr.sim import Simulation

    with _without_pose_graph():
        sim = Simulation(load_any(resolve_scene(scene), seed=None), condition=condition)
        for _ in range(PREPARE_STEPS):
            sim.step()
        twin_steps(sim, say=None, twins=False)  # the turned footprints' and line of sight's kernels
    return PREPARE_STEPS + 1


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
    """``python -m pedvr.warmup SCENE CONDITION`` running beside this process (see the module doc)."""

    def __init__(self, scene: str, condition: str) -> None:
        self.proc: subprocess.Popen[bytes] | None = subprocess.Popen(
            [sys.executable, "-m", "pedvr.warmup", scene, condition], stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.ok: bool | None = None
        atexit.register(self.stop)  # a run that fails before its first step leaves no process behind

    def wait(self) -> bool:
        """Block until the second process is done; True when it compiled everything it meant to."""
        if self.proc is not None:
            self.ok = self.proc.wait() == 0
            self.proc = None
        return bool(self.ok)

    def stop(self) -> None:
        """End the second process if it still runs (a run interrupted while preparing)."""
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self.proc = None


started: Warmer | None = None


def start_if_cold(scene: str, condition: str) -> Warmer | None:
    """Start the second process for ``scene`` (a name or a path) stepped in ``condition`` when the
    cache is cold (once per process); the one started."""
    global started
    if started is None and cold():
        started = Warmer(scene, condition)
    return started


def take() -> Warmer | None:
    """The started second process, handed to the one first step that waits for it."""
    global started
    w, started = started, None
    return w


if __name__ == "__main__":
    scene_kernels(*sys.argv[1:3])
