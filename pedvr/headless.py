"""The headless run: simulate a scene without a window, record and measure.

The one headless entry point (issue 24, "the house"): ``pedvr run --backend
headless``, the fallback when no headset and no display answer, and each run
of ``pedvr sweep`` (:func:`simulate`). Without ``--frames``/``--video``
nothing is rendered and no OpenGL is needed; with them the frame loop of
:mod:`pedvr.xr.run` renders offscreen through EGL
(:mod:`pedvr.xr.offscreen`), taking frames at the requested simulated times.
The files a run leaves are written by :mod:`pedvr.outputs`, which the
backends share.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from pedvr import warmup
from pedvr.outputs import interrupted_by, save_recording, signals_interrupt, write_outputs
from pedvr.prepare import first_step, set_up, stderr_say
from pedvr.scene.config import SceneConfig
from pedvr.sim import Simulation

if TYPE_CHECKING:
    from pedvr.xr.run import ViewOptions


__all__ = ["run_headless", "save_recording", "simulate"]


def run_headless(
    scene: SceneConfig,
    *,
    duration: float | None,
    seed: int | None,
    condition: str,
    responsibility: float | None,
    record: Path | None,
    metrics_json: Path | None,
    out: Path,
    progress: bool = True,
    view: ViewOptions | None = None,
    personal_space: float | None = None,
    user_walk: str | None = None,
) -> dict[str, object]:
    """Run, save the trajectory and metrics, print a summary; return the metrics.

    With ``view`` naming ``frames`` or ``video``, the run goes through the
    frame loop and renders offscreen (:func:`pedvr.xr.run.run_with_view`).
    """
    if view is not None and (view.frames is not None or view.video is not None):
        from pedvr.xr.run import run_with_view

        return run_with_view(
            scene,
            backend="headless",
            opts=view,
            duration=duration,
            seed=seed,
            condition=condition,
            responsibility=responsibility,
            personal_space=personal_space,
            user_walk=user_walk,
            record=record,
            metrics_json=metrics_json,
            out=out,
            progress=progress,
        )
    sim, extra = simulate(scene, duration=duration, seed=seed, condition=condition,
                          responsibility=responsibility, record=True, progress=progress,
                          personal_space=personal_space, user_walk=user_walk)
    return write_outputs(
        sim, scene, condition=condition, record=record, metrics_json=metrics_json, out=out, extra=extra
    )


def simulate(
    scene: SceneConfig,
    *,
    duration: float | None,
    seed: int | None,
    condition: str,
    responsibility: float | None,
    record: bool,
    progress: bool = False,
    personal_space: float | None = None,
    user_walk: str | None = None,
) -> tuple[Simulation, dict[str, object]]:
    """Step a new :class:`Simulation` for ``duration`` simulated seconds (the scene's by default).

    Returns the simulation and the run's timing keys (``wall_s``, ``setup_s``,
    ``first_step_s``, ``interrupted``, ``realtime_factor``) that go beside its
    summary in the metrics JSON (a sweep's determinism checks leave exactly
    these out, so no other machine-dependent key is added here).
    The first step says on stderr what numba compiles while it runs
    (:func:`pedvr.prepare.first_step`; silent without ``progress``). Ctrl-C,
    SIGTERM or SIGHUP end the run early with ``interrupted`` true (the signal's
    name for the latter two). Used by ``pedvr run --backend headless`` and by
    each run of ``pedvr sweep``.
    """
    duration = scene.duration if duration is None else duration
    t0 = time.perf_counter()
    say = stderr_say if progress else None
    sim, compiled = set_up(
        lambda: Simulation(scene, seed=seed, condition=condition, responsibility=responsibility,
                           record=record, personal_space=personal_space, user_walk=user_walk), say=say)
    first = time.perf_counter()
    first_step(sim, say=say, intro=not compiled, warmer=warmup.take())  # started by pedvr run, if cold
    first_step_s = time.perf_counter() - first
    steps = max(0, math.ceil(duration / sim.dt - 1e-9) - 1)
    bar = tqdm(
        total=steps + 1,
        initial=1,
        unit="step",
        disable=not progress or None,
        file=sys.stderr,
        desc=scene.name,
        leave=False,
    )
    interrupted: bool | str = False
    try:
        with signals_interrupt():
            for _ in range(steps):
                sim.step()
                bar.update(1)
    except KeyboardInterrupt as exc:
        interrupted = interrupted_by(exc)
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    extra: dict[str, object] = {
        "wall_s": round(wall, 3),
        "setup_s": round(first - t0, 3),
        "first_step_s": round(first_step_s, 4),
        "interrupted": interrupted,
        "realtime_factor": round(sim.t / wall, 2) if wall > 0 else None,
    }
    return sim, extra
