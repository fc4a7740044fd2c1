"""Running a sweep: tasks on Dask (or serially in process), results into the table as they arrive.

Each task is submitted to ``dask.distributed`` under its stable key
(``pedvr-<hash>``, :class:`~pedvr.sweep.spec.RunTask`); the client collects
results in the order they finish, writes recordings, merges simulated
participants' stores, and adds one row per task to ``DIR/runs.parquet``
(:mod:`pedvr.sweep.table`). A worker that dies has its task rescheduled by Dask
(up to ``distributed.scheduler.allowed-failures`` times, then the row says
``lost`` and ``--resume`` tries it again); a run that raises is a row with
``status = "error"`` and the sweep goes on.

Where the tasks run: a ``LocalCluster`` of ``workers`` processes with one
thread each (default: one per core) started and closed here; an existing
scheduler by address (``tcp://host:8786``), whose workers must have the same
pedvr version installed (checked before anything is submitted); a caller's own
``distributed.Client``; or, with ``workers = 0``, serially in this process
(no Dask at all: the reference the determinism test compares against).

The output folder holds ``sweep.toml`` (the spec as given), ``sweep.json``
(name, parameters, what ran), ``runs.parquet``, ``recordings/`` when kept,
and ``<study>.sqlite`` for simulated participants.
"""

from __future__ import annotations

import json
import logging
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from pedvr.sweep.errors import SweepError
from pedvr.sweep.spec import ParticipantTask, RunTask, SweepSpec, Task
from pedvr.sweep.table import TABLE_NAME, ResultTable
from pedvr.sweep.task import execute, row_of

MANIFEST = "sweep.json"


@dataclass
class SweepOutcome:
    """What a sweep did: tasks planned, already done (resumed), run now, and how they ended."""

    folder: Path
    planned: int
    skipped: int
    ran: int = 0
    ok: int = 0
    failed: int = 0
    lost: int = 0
    wall_s: float = 0.0
    interrupted: bool = False
    where: str = ""
    errors: list[str] = field(default_factory=list)

    def summary(self) -> str:
        rate = f", {60.0 * self.ran / self.wall_s:.1f} runs/min" if self.wall_s > 0 and self.ran else ""
        head = (
            f"sweep {'interrupted' if self.interrupted else 'finished'} in {self.wall_s:.1f} s on "
            f"{self.where}: {self.ran} of {self.planned} runs ran now ({self.ok} ok, {self.failed} failed, "
            f"{self.lost} lost){rate}"
        )
        if self.skipped:
            head += f"; {self.skipped} were done before (resumed)"
        lines = [head, f"results: {self.folder / TABLE_NAME}"]
        lines += [f"  failed: {e}" for e in self.errors[:5]]
        if len(self.errors) > 5:
            lines.append(f"  ... and {len(self.errors) - 5} more (the table's error column has them all)")
        if self.interrupted or self.lost:
            lines.append("continue with --resume: it runs only what is missing")
        return "\n".join(lines)


def prepare_folder(spec: SweepSpec, out: Path, *, resume: bool) -> dict[str, Any]:
    """Create or check the output folder; return its manifest."""
    manifest_path = out / MANIFEST
    if out.exists() and not out.is_dir():
        raise SweepError(f"--out {out}: exists and is not a folder")
    if (out / TABLE_NAME).is_file():  # a manifest alone: a sweep that never finished a run
        if not resume:
            raise SweepError(
                f"{out} already holds a sweep; continue it with --resume, or choose another --out"
            )
        old = json.loads(manifest_path.read_text()) if manifest_path.is_file() else {}
        if old.get("name", spec.name) != spec.name:
            raise SweepError(
                f"{out} holds sweep {old.get('name')!r}, not {spec.name!r}; resume it with its own "
                "spec, or choose another --out"
            )
    out.mkdir(parents=True, exist_ok=True)
    manifest = {
        "name": spec.name,
        "spec": spec.source,
        "kind": "participants" if spec.study else "runs",
        "parameters": list(spec.parameters),
        "swept": list(spec.swept),
        "scenes": list(spec.scenes),
        "study": spec.study,
        "tasks": len(spec.tasks),
        "pedvr_version": spec.tasks[0].version if spec.tasks else None,
    }
    (out / "sweep.toml").write_text(spec.text)
    tmp = manifest_path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(manifest, indent=2) + "\n")
    os.replace(tmp, manifest_path)
    return manifest


def run_sweep(
    spec: SweepSpec,
    *,
    out: Path,
    resume: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    client: Any = None,
    progress: bool = True,
    flush_s: float = 2.0,
    on_result: Callable[[dict[str, Any]], None] | None = None,
    stream: TextIO | None = None,
) -> SweepOutcome:
    """Run every task of ``spec`` that ``out`` does not hold yet; see the module docstring.

    ``on_result`` is called with each row after it is added (tests use it to
    kill a worker or interrupt the sweep part way). Ctrl-C (or a
    KeyboardInterrupt from ``on_result``) stops the sweep cleanly: rows so far
    are written, the cluster is closed, and the outcome says ``interrupted``.
    """
    if scheduler is not None and workers is not None:
        raise SweepError(
            "--workers starts a local cluster; with --scheduler the cluster's own workers run "
            "the sweep (start them with `dask worker ADDRESS`)"
        )
    manifest = prepare_folder(spec, out, resume=resume)
    table = ResultTable(out, flush_s=flush_s, metadata={"pedvr.sweep": json.dumps(manifest)})
    planned = {t.key for t in spec.tasks}
    stray = table.keys() - planned
    if stray:
        raise SweepError(
            f"{out}: {len(stray)} of its rows are runs this spec does not plan (another spec or pedvr "
            "version); resume with the spec that started it, or choose another --out"
        )
    done = table.finished_keys()
    todo = [t for t in spec.tasks if t.key not in done]
    outcome = SweepOutcome(folder=out, planned=len(spec.tasks), skipped=len(spec.tasks) - len(todo))
    store = out / f"{spec.study}.sqlite" if spec.study else None
    stream = stream or sys.stderr

    from tqdm import tqdm

    bar = tqdm(
        total=len(todo),
        desc=spec.name,
        unit="run",
        file=stream,
        disable=not progress or None,
        dynamic_ncols=True,
    )

    def take(task: Task, result: dict[str, Any]) -> None:
        recording = None
        blob = result.get("blob")
        if blob is not None and isinstance(task, RunTask):
            recording = f"recordings/{task.scene_name}-seed{task.seed}-{task.key[:10]}.npz"
            _write_atomic(out / recording, blob)
        elif blob is not None and isinstance(task, ParticipantTask):
            from pedvr.sweep.participants import merge_participant

            assert store is not None
            merge_participant(store, blob, task.participant)
        row = row_of(task, result, recording=recording)
        table.add(row)
        outcome.ran += 1
        status = row["status"]
        if status == "ok":
            outcome.ok += 1
        elif status == "lost":
            outcome.lost += 1
            outcome.errors.append(f"{task.describe()}: {row['error']}")
        else:
            outcome.failed += 1
            outcome.errors.append(f"{task.describe()}: {row['error']}")
        bar.set_postfix(ok=outcome.ok, failed=outcome.failed + outcome.lost, refresh=False)
        bar.update(1)
        if on_result is not None:
            on_result(row)

    t0 = time.perf_counter()
    own: list[Any] = []
    try:
        if not todo:
            outcome.where = "nothing to run"
        elif workers == 0 and client is None and scheduler is None:
            outcome.where = "this process, serially"
            for task in todo:
                take(task, execute(task))
        else:
            if client is None:
                client, own = _connect(scheduler=scheduler, workers=workers)
            outcome.where = _describe(client, scheduler)
            _check_workers(client)
            _run_on_dask(client, todo, take, idle=table.flush, every_s=flush_s)
    except KeyboardInterrupt:
        outcome.interrupted = True
    finally:
        table.flush()
        bar.close()
        for thing in reversed(own):
            thing.close()
        outcome.wall_s = time.perf_counter() - t0
    return outcome


def _write_atomic(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _connect(*, scheduler: str | None, workers: int | None) -> tuple[Any, list[Any]]:
    """A client to the scheduler at ``scheduler``, or to a new LocalCluster of ``workers`` processes."""
    from distributed import Client

    if scheduler is not None:
        try:
            # Dask's own connect timeout (distributed.comm.timeouts.connect, 30 s by default).
            client = Client(scheduler)
        except (OSError, TimeoutError, ValueError) as exc:
            raise SweepError(
                f"--scheduler {scheduler}: cannot reach a Dask scheduler there ({exc})"
            ) from None
        try:
            client.wait_for_workers(1, timeout=30)
        except TimeoutError:
            client.close()
            raise SweepError(
                f"--scheduler {scheduler}: no worker joined within 30 s; start some with "
                f"`dask worker {scheduler}`"
            ) from None
        return client, [client]
    return start_local_cluster(workers)


def start_local_cluster(workers: int | None) -> tuple[Any, list[Any]]:
    """A client on a new LocalCluster of ``workers`` processes (default: one per core), and the
    things to close (in reverse order) when done."""
    from distributed import Client, LocalCluster

    n = workers if workers is not None else (os.cpu_count() or 1)
    # One thread per worker, and numba's kernels single-threaded inside it: the
    # parallelism is across runs, one per core. The worker processes start with
    # Ctrl-C ignored (inherited through exec): a terminal's Ctrl-C reaches the
    # whole process group, and only this process should handle it, by writing
    # the table and closing the cluster, not every worker with a traceback.
    main = threading.current_thread() is threading.main_thread()  # signals are the main thread's
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    try:
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            env={"NUMBA_NUM_THREADS": "1"},
            silence_logs=logging.ERROR,  # a rerun task is in the table's story, not a warning on the screen
        )
    finally:
        if main:
            signal.signal(signal.SIGINT, previous)
    client = Client(cluster)
    return client, [cluster, client]


def _describe(client: Any, scheduler: str | None) -> str:
    n = len(client.nthreads())
    return f"{n} Dask workers at {scheduler}" if scheduler else f"{n} local Dask workers"


def _worker_version() -> str:
    from pedvr.sweep.spec import pedvr_version

    return pedvr_version()


def _check_workers(client: Any) -> None:
    """Every worker runs the same pedvr version as this client (the task keys include it)."""
    mine = _worker_version()
    try:
        versions = client.run(_worker_version)
    except ImportError as exc:
        raise SweepError(
            f"a Dask worker cannot import pedvr ({exc}); install pedvr with the sweep extra on every "
            "worker: pip install 'pedvr[sweep]'"
        ) from None
    odd = {w: v for w, v in versions.items() if v != mine}
    if odd:
        w, v = next(iter(odd.items()))
        raise SweepError(
            f"Dask worker {w} runs pedvr {v}, this client {mine}; install the same version on "
            f"every worker ({len(odd)} differ)"
        )


def _run_on_dask(
    client: Any,
    todo: list[Task],
    take: Callable[[Task, dict[str, Any]], None],
    *,
    idle: Callable[[], None],
    every_s: float,
) -> None:
    """Submit every task under its stable key; hand each result to ``take`` as it arrives, and call
    ``idle`` (write buffered rows) when none has arrived for ``every_s`` seconds."""
    done: queue.Queue[Any] = queue.Queue()
    futures = {}
    tasks = {}
    submitted = client.map(execute, todo, key=[f"pedvr-{t.key}" for t in todo], pure=False)
    for task, fut in zip(todo, submitted, strict=True):
        futures[fut.key] = fut
        tasks[fut.key] = task
        fut.add_done_callback(done.put)
    try:
        while futures:
            try:
                fut = done.get(timeout=every_s)
            except queue.Empty:
                idle()
                continue
            key = fut.key
            if key not in futures:
                continue
            task = tasks.pop(key)
            futures.pop(key)
            if fut.status == "finished":
                result = fut.result()
            else:
                result = {"key": task.key, "metrics": {}, "blob": None, **_failure(fut)}
            fut.release()
            take(task, result)
    finally:
        for fut in futures.values():
            fut.cancel()


def _failure(fut: Any) -> dict[str, str]:
    """Status and error of a future that did not finish: ``lost`` (to be run again on resume) when
    its workers died or the scheduler dropped it, ``error`` when Dask itself raised."""
    from distributed import KilledWorker

    if fut.status == "cancelled":  # not by us: a scheduler restart, or a key dropped while resubmitted
        return {"status": "lost", "error": "the Dask scheduler cancelled it"}
    exc = fut.exception()
    if isinstance(exc, KilledWorker):
        return {"status": "lost", "error": "its worker died each time it ran it (Dask's allowed-failures)"}
    return {"status": "error", "error": f"{type(exc).__name__}: {exc}"}
