"""``pedvr sweep SPEC.toml [--scheduler ADDRESS] [--workers N] [--out DIR] [--resume
[--allow-mixed-code]]``, ``pedvr sweep report DIR [--metric NAME ...]`` and ``pedvr bench sweep``.

``pedvr/cli.py`` wires these in with :func:`add_sweep_parser`,
:func:`add_bench_parser`, :func:`run_sweep_command` and :func:`run_bench_command`.
Exit codes: 0 when every run is ok, 1 when some failed or were lost, 130 when
interrupted (the table keeps what finished; ``--resume`` continues).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, TextIO

from pedvr.argtypes import count as _count
from pedvr.argtypes import positive
from pedvr.errors import UsageError
from pedvr.sweep.errors import SweepError


def add_sweep_parser(subparsers: Any) -> argparse.ArgumentParser:
    """``sweep``: run a spec, or ``sweep report DIR``."""
    sw = subparsers.add_parser(
        "sweep",
        help="many headless runs from one spec, on Dask; or `sweep report DIR`",
        description="Run a sweep spec (pedvr sweep SPEC.toml) or write the report of one "
        "(pedvr sweep report DIR).",
    )
    sw.add_argument("spec", help="sweep spec (.toml), or 'report'")
    sw.add_argument("dir", nargs="?", default=None, help="with 'report': the sweep's output folder")
    sw.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="an existing Dask scheduler, e.g. tcp://host:8786 (default: a local cluster)",
    )
    sw.add_argument(
        "--workers",
        type=_count,
        default=None,
        metavar="N",
        help="local cluster size (default: one per core); 0 runs serially in this process",
    )
    sw.add_argument(
        "--out", type=Path, default=None, metavar="DIR", help="output folder (default: pedvr-out/sweep-NAME)"
    )
    sw.add_argument(
        "--resume",
        action="store_true",
        help="run only what DIR does not hold yet, and its failed or lost runs again",
    )
    sw.add_argument(
        "--allow-mixed-code",
        action="store_true",
        help="with --resume: add rows even though DIR's rows were made by other code (pedvr commit, "
        "uncommitted changes, numpy, numba or dask version); each row records its code",
    )
    sw.add_argument("--quiet", action="store_true", help="no progress bar")
    sw.add_argument(
        "--metric",
        action="append",
        default=None,
        metavar="NAME",
        help="with 'report': plot this column (repeatable; default: the outcome measures that vary)",
    )
    return sw


def add_bench_parser(bench_subparsers: Any) -> argparse.ArgumentParser:
    """``bench sweep``: runs per minute on local Dask workers against a serial loop."""
    b = bench_subparsers.add_parser("sweep", help="sweep throughput: local Dask workers vs a serial loop")
    b.add_argument("--runs", type=_count, default=100)
    b.add_argument("--workers", type=_count, default=2)
    b.add_argument("--scene", default="headon_corridor")
    b.add_argument("--duration", type=positive(float), default=2.0, help="simulated seconds per run")
    b.add_argument("--json", action="store_true")
    from pedvr.measure.cli import add_realism_parser  # `bench realism` (issue 26; run by pedvr.cli)

    add_realism_parser(bench_subparsers)
    return b


def _need_extra() -> None:
    try:
        import distributed  # noqa: F401
        import pyarrow  # noqa: F401
    except ImportError as exc:
        raise SweepError(
            f"pedvr sweep needs the sweep extra ({exc.name} is missing): pip install -e '.[sweep]'"
        ) from None


def run_sweep_command(args: argparse.Namespace, *, stdout: TextIO | None = None) -> int:
    """Run a parsed ``sweep`` command; return the exit code. Raises PedvrError on bad input."""
    out = stdout or sys.stdout
    _need_extra()
    if args.spec == "report":
        if args.dir is None:
            raise UsageError("pedvr sweep report: give the sweep's output folder: pedvr sweep report DIR")
        given = [
            f
            for f, v in (
                ("--scheduler", args.scheduler),
                ("--workers", args.workers),
                ("--out", args.out),
                ("--resume", args.resume or None),
                ("--allow-mixed-code", args.allow_mixed_code or None),
            )
            if v is not None
        ]
        if given:
            raise UsageError(f"pedvr sweep report: {given[0]} applies to running a sweep, not to its report")
        from pedvr.sweep.report import write_sweep_report

        md = write_sweep_report(Path(args.dir), metrics=args.metric)
        print(f"report: {md}", file=out)
        return 0
    if args.dir is not None:
        raise UsageError(f"pedvr sweep: unexpected argument {args.dir!r} (the output folder is --out DIR)")
    if args.metric:
        raise UsageError("pedvr sweep: --metric applies to the report: pedvr sweep report DIR --metric NAME")
    if args.allow_mixed_code and not args.resume:
        raise UsageError("pedvr sweep: --allow-mixed-code applies to --resume")
    from pedvr.sweep.runner import run_sweep
    from pedvr.sweep.spec import load_spec

    spec = load_spec(args.spec)
    folder = args.out or Path("pedvr-out") / f"sweep-{spec.name}"
    print(f"sweep {spec.name}: {len(spec.tasks)} runs into {folder}", file=out)
    outcome = run_sweep(
        spec,
        out=folder,
        resume=args.resume,
        allow_mixed_code=args.allow_mixed_code,
        workers=args.workers,
        scheduler=args.scheduler,
        progress=not args.quiet,
    )
    print(outcome.summary(), file=out)
    if spec.study:
        store = folder / f"{spec.study}.sqlite"
        print(f"study store: {store} (pedvr study analyze {store})", file=out)
    print(f"report: pedvr sweep report {folder}", file=out)
    if outcome.interrupted:
        return 130
    return 0 if outcome.failed + outcome.lost == 0 else 1


def run_bench_command(args: argparse.Namespace, *, stdout: TextIO | None = None) -> int:
    _need_extra()
    result = bench_sweep(runs=args.runs, workers=args.workers, scene=args.scene, duration=args.duration)
    out = stdout or sys.stdout
    if args.json:
        print(json.dumps(result, indent=2), file=out)
    else:
        print(", ".join(f"{k}={v}" for k, v in result.items()), file=out)
    return 0


def bench_sweep(*, runs: int, workers: int, scene: str, duration: float) -> dict[str, Any]:
    """Runs per minute for ``runs`` short runs: a plain serial loop in this process, then a sweep on
    ``workers`` local Dask workers (the real path: keys, table, progress off).

    Both sides are warmed first (one run in this process; one per worker), so
    numba's cache loading and scene set-up caches count in neither; the
    cluster's start is reported on its own. ``overhead_per_task_s`` is the core
    time a task costs beyond the run itself: ``(dask wall × workers − serial
    wall) / runs`` (negative values are noise). On a busy machine the workers
    do not get a core each and the runs themselves slow down, so
    ``slot_idle_per_task_s`` separates Dask's own cost: the worker time not spent
    inside the run, ``(dask wall × workers − Σ worker_wall_s) / runs``, where
    ``worker_wall_s`` is each run's time measured on its worker
    (``worker_s_per_run`` is their mean).
    """
    if runs < 1 or workers < 1:
        raise UsageError("pedvr bench sweep: --runs and --workers must be >= 1")
    import pyarrow.parquet  # noqa: F401 - imported before the clock starts, as in a long sweep

    from pedvr.sweep.runner import run_sweep, start_local_cluster
    from pedvr.sweep.spec import parse_spec
    from pedvr.sweep.table import read_table
    from pedvr.sweep.task import execute

    data = {
        "sweep": {
            "name": "bench",
            "scenes": [scene],
            "duration": duration,
            "seeds": {"from": 1, "count": runs},
        }
    }
    spec = parse_spec(data, source="bench", base_dir=Path.cwd())
    warm = parse_spec(
        {"sweep": {**data["sweep"], "seeds": [10_000 + k for k in range(workers + 1)]}},
        source="bench",
        base_dir=Path.cwd(),
    )
    load0 = os.getloadavg()[0]
    execute(warm.tasks[0])
    t0 = time.perf_counter()
    for task in spec.tasks:
        r = execute(task)
        if r["status"] != "ok":
            raise SweepError(f"pedvr bench sweep: a run failed: {r['error']}")
    serial_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    client, own = start_local_cluster(workers)  # as `pedvr sweep --workers N` starts it
    try:
        start_s = time.perf_counter() - t0
        client.gather(
            [
                client.submit(execute, t, pure=False, workers=[w])
                for t, w in zip(warm.tasks[1:], client.nthreads(), strict=False)
            ]
        )
        with tempfile.TemporaryDirectory(prefix="pedvr-bench-sweep-") as tmp:
            t0 = time.perf_counter()
            outcome = run_sweep(spec, out=Path(tmp) / "out", client=client, progress=False)
            dask_s = time.perf_counter() - t0
            in_runs_s = sum(read_table(Path(tmp) / "out").column("worker_wall_s").to_pylist())
    finally:
        for thing in reversed(own):
            thing.close()
    if outcome.ok != runs:
        raise SweepError(f"pedvr bench sweep: {runs - outcome.ok} runs did not finish ok")
    return {
        "runs": runs,
        "workers": workers,
        "scene": scene,
        "duration_s": duration,
        "serial_wall_s": round(serial_s, 6),  # µs: short runs' rates are recomputable from it
        "serial_runs_per_min": round(60 * runs / serial_s, 1),
        "serial_s_per_run": round(serial_s / runs, 4),
        "dask_wall_s": round(dask_s, 6),
        "dask_runs_per_min": round(60 * runs / dask_s, 1),
        "speedup": round(serial_s / dask_s, 3),
        "overhead_per_task_s": round((dask_s * workers - serial_s) / runs, 4),
        "worker_s_per_run": round(in_runs_s / runs, 4),
        "slot_idle_per_task_s": round((dask_s * workers - in_runs_s) / runs, 4),
        "cluster_start_s": round(start_s, 3),
        "load_average_1min_before": round(load0, 2),
        "load_average_1min_after": round(os.getloadavg()[0], 2),
    }
