"""A run's files and summary: the trajectory (``.npz``), the metrics (``.json``), the lines printed,
and how a run is ended early (Ctrl-C, SIGTERM, SIGHUP) with its files still written.

Shared by every backend (:mod:`pedvr.headless`, :mod:`pedvr.xr.run`) and by
``pedvr sweep``; it imports nothing of the backends, so they all import it
and not each other (issue 24, "the house").
"""

from __future__ import annotations

import json
from contextlib import AbstractContextManager
from pathlib import Path

from pedvr.scene.config import SceneConfig
from pedvr.sim import Simulation


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
    if summary.get("interrupted"):
        how = "Ctrl-C" if summary["interrupted"] is True else summary["interrupted"]
        print(f"  interrupted by {how} at t = {sim.t:.1f} s: the outputs cover the run so far")
    print(f"  trajectory: {record}")
    print(f"  metrics:    {metrics_json}")
    return summary


def interrupted_by(exc: KeyboardInterrupt) -> bool | str:
    """``interrupted`` in the metrics: True for Ctrl-C, the signal's name for SIGTERM / SIGHUP."""
    from pedvr.signals import TerminatedBySignal

    return exc.name if isinstance(exc, TerminatedBySignal) else True


def signals_interrupt() -> AbstractContextManager[None]:
    """SIGTERM and SIGHUP end a run like Ctrl-C inside this block: the outputs are written
    (:func:`pedvr.signals.signals_abort`, the study's handler, reused)."""
    from pedvr.signals import signals_abort

    return signals_abort()
