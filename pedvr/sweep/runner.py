"""Running a sweep: tasks on Dask (or serially in process), results into the table as they arrive.

Each task is submitted to ``dask.distributed`` under its stable key
(``pedvr-<hash>``, :class:`~pedvr.sweep.spec.RunTask`); the client collects
results in the order they finish, writes recordings, merges simulated
participants' stores, and adds one row per task to ``DIR/runs.parquet``
(:mod:`pedvr.sweep.table`). A worker that dies has its task rescheduled by Dask
(up to ``distributed.scheduler.allowed-failures`` times, then the row says
``lost``); a worker that dies holding a finished result the client has not
fetched yet loses that result, and Dask computes it again: the client waits
for it (issue 25.7: it used to write an ``error`` row, ``NoneType: None``). A
run that raises is a row with ``status = "error"`` and the sweep goes on.
``--resume`` runs what the table lacks and every ``error`` or ``lost`` row
again; it refuses to add rows to a table made by other code
(:mod:`pedvr.provenance`) unless told ``allow_mixed_code``.

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

from pedvr.provenance import describe, differences, provenance
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
    retried: int = 0  # of ``ran``: tasks whose earlier row was an error or lost
    code: str = ""  # the code that ran them (provenance.describe)
    mixed: list[str] = field(default_factory=list)  # how the table's earlier rows' code differs

    def summary(self) -> str:
        rate = f", {60.0 * self.ran / self.wall_s:.1f} runs/min" if self.wall_s > 0 and self.ran else ""
        head = (
            f"sweep {'interrupted' if self.interrupted else 'finished'} in {self.wall_s:.1f} s on "
            f"{self.where}: {self.ran} of {self.planned} runs ran now ({self.ok} ok, {self.failed} failed, "
            f"{self.lost} lost){rate}"
        )
        if self.skipped:
            head += f"; {self.skipped} were done before (resumed)"
        if self.retried:
            head += f"; {self.retried} failed or lost before and ran again"
        lines = [head, f"results: {self.folder / TABLE_NAME}"]
        if self.code:
            lines.append(f"code: {self.code}")
        if self.mixed:
            lines.append(
                "note: the table now holds rows from different code (--allow-mixed-code): "
                + "; ".join(self.mixed)
            )
        lines += [f"  failed: {e}" for e in self.errors[:5]]
        if len(self.errors) > 5:
            lines.append(f"  ... and {len(self.errors) - 5} more (the table's error column has them all)")
        if self.interrupted or self.lost or self.failed:
            lines.append("continue with --resume: it runs what is missing, failed or lost")
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
        "code": provenance(),  # the client's, when the sweep last started (each row has its worker's)
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
    allow_mixed_code: bool = False,
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
    With ``resume``, the table's ``ok`` rows must come from this code (see
    :func:`pedvr.provenance.differences`), or ``allow_mixed_code``.
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
    mixed = _code_differences(table)
    if mixed and not allow_mixed_code:
        raise SweepError(
            f"{out}: its rows were made by other code than this ({'; '.join(mixed)}); resume with "
            "--allow-mixed-code to add rows anyway (each row records its code), or choose another --out"
        )
    done = table.finished_keys()
    failed_before = set(table.status_of(("error", "lost")))
    todo = [t for t in spec.tasks if t.key not in done]
    outcome = SweepOutcome(folder=out, planned=len(spec.tasks), skipped=len(spec.tasks) - len(todo))
    outcome.retried = sum(t.key in failed_before for t in todo)
    outcome.code = describe(provenance())
    outcome.mixed = mixed
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


def _code_differences(table: ResultTable) -> list[str]:
    """How the code of the table's ``ok`` rows differs from this process's (one entry per
    distinct code that differs: ``N rows: field old → new, ...``)."""
    mine = provenance()
    out = []
    for code, n in table.provenances():
        diff = differences(code, mine)
        if diff:
            out.append(f"{n} row{'s' if n != 1 else ''}: {', '.join(diff)}")
    return out


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


def _worker_code() -> dict[str, Any]:
    from pedvr.provenance import provenance

    return provenance()


def _check_workers(client: Any) -> None:
    """Every worker runs the same pedvr version as this client (the task keys include it), and no
    other code where both know it (:func:`pedvr.provenance.differences`)."""
    mine = _worker_code()
    try:
        codes = client.run(_worker_code)
    except ImportError as exc:
        raise SweepError(
            f"a Dask worker cannot import pedvr ({exc}); install pedvr with the sweep extra on every "
            "worker: pip install 'pedvr[sweep]'"
        ) from None
    odd = {w: c for w, c in codes.items() if c.get("pedvr_version") != mine["pedvr_version"]}
    if odd:
        w, c = next(iter(odd.items()))
        raise SweepError(
            f"Dask worker {w} runs pedvr {c.get('pedvr_version')}, this client {mine['pedvr_version']}; "
            f"install the same version on every worker ({len(odd)} differ)"
        )
    other = {w: differences(c, mine) for w, c in codes.items() if differences(c, mine)}
    if other:
        w, diff = next(iter(other.items()))
        raise SweepError(
            f"Dask worker {w} runs other code than this client ({', '.join(diff)}); install the same "
            f"code on every worker ({len(other)} differ)"
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
    ``idle`` (write buffered rows) when none has arrived for ``every_s`` seconds.

    A future's done-callback fires once. When the worker holding its result dies before the
    result is fetched, the future turns ``lost`` (or ``pending`` again) and Dask computes the task
    anew; such a future is not done: it waits in ``recomputing`` and is polled every
    :data:`_POLL_S` until it settles (finished, failed or cancelled)."""
    done: queue.Queue[Any] = queue.Queue()
    futures = {}
    tasks = {}
    recomputing: dict[str, Any] = {}
    submitted = client.map(execute, todo, key=[f"pedvr-{t.key}" for t in todo], pure=False)
    for task, fut in zip(todo, submitted, strict=True):
        futures[fut.key] = fut
        tasks[fut.key] = task
        fut.add_done_callback(done.put)
    try:
        while futures:
            try:
                arrived = [done.get(timeout=_POLL_S if recomputing else every_s)]
            except queue.Empty:
                arrived = []
                idle()
            arrived += [f for f in recomputing.values() if f.status in _SETTLED]
            for fut in arrived:
                key = fut.key
                if key not in futures:
                    continue
                if fut.status not in _SETTLED:  # its result was lost with a worker: computed again
                    recomputing[key] = fut
                    continue
                recomputing.pop(key, None)
                task = tasks.pop(key)
                futures.pop(key)
                result = _result(fut, task)
                fut.release()
                take(task, result)
    finally:
        for fut in futures.values():
            fut.cancel()


_SETTLED = ("finished", "error", "cancelled")
_POLL_S = 0.2  # s between looks at futures whose result is being computed again


def _result(fut: Any, task: Task) -> dict[str, Any]:
    """A settled future's result; a failure's row when Dask could not deliver one."""
    if fut.status == "finished":
        try:
            # Dask fetches it from the worker holding it; if that worker dies meanwhile, Dask
            # computes it again and this waits (distributed's gather resets lost keys).
            return dict(fut.result())
        except Exception:  # noqa: BLE001 - it failed after all: classified below
            pass
    return {"key": task.key, "metrics": {}, "blob": None, **_failure(fut)}


def _failure(fut: Any) -> dict[str, str]:
    """Status and error of a future that did not finish: ``lost`` (to be run again on resume) when
    its workers died or the scheduler dropped it, ``error`` when Dask itself raised."""
    from distributed import KilledWorker

    if fut.status == "cancelled":  # not by us: a scheduler restart, or a key dropped while resubmitted
        return {"status": "lost", "error": "the Dask scheduler cancelled it"}
    exc = fut.exception() if fut.status == "error" else None
    if isinstance(exc, KilledWorker):
        return {"status": "lost", "error": "its worker died each time it ran it (Dask's allowed-failures)"}
    if exc is None:  # no exception to report: Dask did not deliver the result
        return {"status": "lost", "error": f"Dask did not deliver its result (future {fut.status})"}
    return {"status": "error", "error": f"{type(exc).__name__}: {exc}"}
