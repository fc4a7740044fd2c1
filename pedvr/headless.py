"""The headless run: simulate a scene without a window, record and measure.

Used by ``pedvr run --backend headless`` and as the fallback when no headset
and no display answer. Without ``--frames``/``--video`` nothing is rendered
and no OpenGL is needed; with them the frame loop renders offscreen through
EGL (:mod:`pedvr.xr.headless`).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from tqdm import tqdm

from pedvr.scene.config import SceneConfig
from pedvr.sim import Simulation

if TYPE_CHECKING:
    from pedvr.xr.run import ViewOptions


def run_tag(scene: SceneConfig, *, seed: int | None, condition: str) -> str:
    return f"{scene.name}-seed{scene.seed if seed is None else seed}-{condition.replace('+', '-')}"


def save_recording(sim: Simulation, scene: SceneConfig, summary: dict[str, object], path: Path) -> None:
    """Save the run's trajectory (``.npz``) with its ``meta``: scene, content hash, seed, condition."""
    meta = {k: summary[k] for k in ("scene", "scene_hash", "seed", "condition", "responsibility",
                                    "personal_space_m", "user_walk", "dt")}
    meta["source"] = scene.source
    if summary.get("door_events"):  # door etiquette: who held for whom, HOF/HOL/NH, waits, thank-yous
        meta["door_events"] = summary["door_events"]
    assert sim.recording is not None
    sim.recording.save(path, meta)


def write_outputs(
    sim: Simulation,
    scene: SceneConfig,
    *,
    condition: str,
    record: Path | None,
    metrics_json: Path | None,
    out: Path,
    extra: dict[str, object],
) -> dict[str, object]:
    """Save the trajectory (``.npz``) and metrics (``.json``, the summary plus ``extra``); print a summary."""
    tag = run_tag(scene, seed=sim.seed, condition=condition)
    record = record or out / f"{tag}.npz"
    metrics_json = metrics_json or out / f"{tag}.json"
    for p in (record, metrics_json):
        p.parent.mkdir(parents=True, exist_ok=True)
    summary = sim.summary()
    summary.update(extra)
    save_recording(sim, scene, summary, record)
    metrics_json.write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n")

    print(
        f"scene {scene.name} ({scene.source}), seed {sim.seed}, condition {condition}, "
        f"responsibility {sim.responsibility}"
    )
    wall = float(summary.get("wall_s") or 0.0)  # type: ignore[arg-type]
    print(
        f"  {summary['steps']} steps of {sim.dt * 1e3:.2f} ms = {sim.t:.1f} s simulated in {wall:.1f} s "
        f"({summary.get('realtime_factor')}x real time)"
    )
    # No user (a SteerSuite case, user.enabled = false), or no agent beside one: no distance to print.
    near = summary["min_user_distance_m"]
    user = (
        "no user in the scene" if sim.user is None
        else "no agents, so no distance to the user" if near is None else f"min distance to user {near} m"
    )
    print(f"  agents {summary['agents']}, arrivals {summary['arrivals']}, mean speed "
          f"{summary['mean_speed_mps']} m/s, {user}")
    into = "" if sim.user is None else f", into the user {summary['user_overlap_max_m']} m"
    print(f"  max overlap {summary['max_overlap_m']} m, pairs overlapping > 1 cm: "
          f"{summary['overlaps_over_1cm']}{into}")
    if summary.get("user_clearance_p50_m") is not None:
        print(f"  clearance to the user p5 {summary['user_clearance_p5_m']} m, p50 "
              f"{summary['user_clearance_p50_m']} m; steps inside the personal space "
              f"{summary['steps_in_user_margin']}")
    print(f"  step time p50 {summary['step_ms_p50']} ms, p95 {summary['step_ms_p95']} ms")
    print(f"  trajectory: {record}")
    print(f"  metrics:    {metrics_json}")
    return summary


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
    summary in the metrics JSON. Ctrl-C ends the run early with
    ``interrupted`` true. Used by ``pedvr run --backend headless`` and by each
    run of ``pedvr sweep``.
    """
    duration = scene.duration if duration is None else duration
    t0 = time.perf_counter()
    sim = Simulation(scene, seed=seed, condition=condition, responsibility=responsibility, record=record,
                     personal_space=personal_space, user_walk=user_walk)
    first = time.perf_counter()
    sim.step()
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
    interrupted = False
    try:
        for _ in range(steps):
            sim.step()
            bar.update(1)
    except KeyboardInterrupt:
        interrupted = True
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
