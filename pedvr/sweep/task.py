"""What a worker does with one task, and how its result becomes a table row.

:func:`execute` is the function Dask runs (and the serial mode calls in
process). It never raises for a run's own failure: a run that raises returns
``status = "error"`` with the error's one-line message, so the sweep records
it and goes on (retrying a deterministic failure would fail again). Only a
worker that dies is retried, by Dask.

A result is a plain dict: ``key``, ``status``, ``error``, ``metrics`` (the
run's metrics JSON, as ``pedvr run --metrics-json`` writes it, plus SteerBench
scores when asked), ``provenance`` (the worker's code:
:mod:`pedvr.provenance`), and ``blob``: the run's ``.npz`` recording when
recordings are kept, a simulated participant's SQLite store; the client writes
or merges it, so workers need no shared filesystem.
"""

from __future__ import annotations

import io
import json
import math
import time
import traceback
from typing import Any

import numpy as np

from pedvr.provenance import COLUMNS as PROVENANCE
from pedvr.provenance import provenance
from pedvr.sweep.spec import ParticipantTask, RunTask, Task

# Columns that measure the machine rather than the simulation: they differ
# between two runs of the same task, and the determinism checks leave them out.
TIMING_COLUMNS = (
    "wall_s",
    "setup_s",
    "first_step_s",
    "realtime_factor",
    "step_ms_p50",
    "step_ms_p95",
    "worker_wall_s",
)
TIMING_PREFIXES = ("phase_ms_mean.",)


def is_timing(column: str) -> bool:
    return column in TIMING_COLUMNS or column.startswith(TIMING_PREFIXES)


def execute(task: Task) -> dict[str, Any]:
    """Run one task; always returns a result dict (see the module docstring)."""
    t0 = time.perf_counter()
    try:
        metrics, blob = _run(task) if isinstance(task, RunTask) else _participant(task)
        status, error = "ok", None
    except Exception as exc:  # noqa: BLE001 - a run's failure is recorded, not raised
        metrics, blob = {}, None
        status, error = "error", _one_line(exc)
    metrics["worker_wall_s"] = round(time.perf_counter() - t0, 3)
    return {
        "key": task.key,
        "status": status,
        "error": error,
        "metrics": metrics,
        "blob": blob,
        "provenance": provenance(),
    }


def _one_line(exc: BaseException) -> str:
    """The error's message and where it was raised, on one line."""
    from pedvr.errors import PedvrError

    msg = " / ".join(str(exc).splitlines()) or type(exc).__name__
    if isinstance(exc, PedvrError):
        return msg
    tb = traceback.extract_tb(exc.__traceback__)
    where = f" (at {tb[-1].filename.rsplit('/', 2)[-1]}:{tb[-1].lineno})" if tb else ""
    return f"{type(exc).__name__}: {msg}{where}"


def _run(task: RunTask) -> tuple[dict[str, Any], bytes | None]:
    from pedvr.headless import save_recording, simulate

    scene = task.scene.load(task.seed)
    sim, extra = simulate(
        scene,
        duration=task.duration,
        seed=task.seed,
        condition=task.condition,
        responsibility=task.responsibility,
        record=task.keep_recording or task.steerbench,
        personal_space=task.personal_space,
        user_walk=task.user_walk,
    )
    summary = sim.summary()
    summary.update(extra)
    if task.steerbench:
        import numpy as np

        from pedvr.sweep.steerbench import radii_by_id, steerbench_scores

        assert sim.recording is not None
        arrays = sim.recording.arrays()
        radius = radii_by_id(scene, int(arrays["ids"].max()) + 1)
        if not np.array_equal(radius[sim.crowd.ids], sim.crowd.radius):  # the spawn order is the id order
            raise RuntimeError("steerbench: agent radii do not follow the scene's spawn order")
        summary["steerbench"] = steerbench_scores(arrays, scene=scene, radius=radius[arrays["ids"]])
    if not task.keep_recording:
        return summary, None
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory(prefix="pedvr-sweep-") as tmp:
        path = Path(tmp) / "run.npz"
        save_recording(sim, scene, summary, path)
        return summary, path.read_bytes()


def _participant(task: ParticipantTask) -> tuple[dict[str, Any], bytes]:
    """Run one simulated participant into a private store; the client merges its bytes."""
    import contextlib
    import tempfile
    from pathlib import Path

    from pedvr.study.cli import main as study_main
    from pedvr.sweep.participants import participant_summary

    with tempfile.TemporaryDirectory(prefix="pedvr-sweep-") as tmp:
        db = Path(tmp) / f"{task.participant}.sqlite"
        argv = [
            "run",
            task.protocol,
            "--participant",
            task.participant,
            "--simulated",
            "--backend",
            "headless",
            "--db",
            str(db),
        ]
        if task.max_trial_s is not None:
            argv += ["--max-trial-seconds", repr(task.max_trial_s)]
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = study_main(argv)
        if code != 0:
            lines = [ln for ln in (err.getvalue() + out.getvalue()).splitlines() if ln.strip()]
            raise RuntimeError(f"pedvr study run exited {code}: " + (lines[-1] if lines else "no output"))
        return participant_summary(db, task.participant), db.read_bytes()


def flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested dicts become dotted keys; lists become JSON text; non-finite floats become None."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        elif isinstance(v, list | tuple):
            out[key] = json.dumps(v, sort_keys=True, default=str)
        elif isinstance(v, float) and not math.isfinite(v):
            out[key] = None
        elif v is None or isinstance(v, bool | int | float | str):
            out[key] = v
        elif isinstance(v, np.generic):
            out.update(flatten({k: v.item()}, prefix))
        else:
            out[key] = str(v)
    return out


def row_of(task: Task, result: dict[str, Any], *, recording: str | None = None) -> dict[str, Any]:
    """The table row of a finished task: its columns, status, error, the code that ran it (null
    where no worker ran it: a lost task), then every metric (flattened).

    Metric keys that repeat a run column (``scene``, ``seed``, ``condition``,
    ``responsibility``) are the same quantity; the run's column is kept.
    """
    row = task.columns()
    row["status"] = result["status"]
    row["error"] = result["error"]
    code = result.get("provenance") or {}
    for k in PROVENANCE:
        row[k] = code.get(k, row.get(k))
    if recording is not None:
        row["recording"] = recording
    for k, v in flatten(result["metrics"]).items():
        row.setdefault(k, v)
    return row
