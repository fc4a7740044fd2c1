"""CPU contention for benchmarks: ``K`` busy processes beside a measurement (issue 12).

In a headset the simulation never has the machine to itself; ``pedvr bench ... --load K``
measures the same keys with ``K`` CPU-bound processes running beside it::

    with cpu_load(2) as load:
        ...  # time the kernels
    load.pids  # the busy processes' ids (they are gone after the block)

Each busy process is a pure-Python loop in a fresh interpreter (``sys.executable -c``), one core
each, no numpy, no files. It also polls its parent's id and exits on its own if the benchmark
dies without stopping it, so no spinner outlives the measurement. ``cpu_load(0)`` starts nothing.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from pedvr.errors import UsageError

_BUSY = (
    "import os\n"
    "parent = os.getppid()\n"
    "while os.getppid() == parent:\n"
    "    x = 0\n"
    "    for i in range(200000):\n"
    "        x += i * i\n"
)
SETTLE_S = 0.3  # s: let the spinners get scheduled before the measurement starts
MAX_LOAD = 64


@dataclass
class Load:
    """The running busy processes (``pids``) and the load averages around the measurement."""

    k: int
    pids: list[int] = field(default_factory=list)
    loadavg_before: tuple[float, float, float] = (0.0, 0.0, 0.0)
    loadavg_after: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def describe(self) -> dict[str, object]:
        """JSON-able keys for a benchmark result."""
        return {"load_processes": self.k, "loadavg_before": [round(x, 2) for x in self.loadavg_before],
                "loadavg_after": [round(x, 2) for x in self.loadavg_after]}


def check_load(k: object) -> int:
    """``k`` as a process count, or :class:`UsageError` naming it."""
    if isinstance(k, bool) or not isinstance(k, int) or not 0 <= k <= MAX_LOAD:
        raise UsageError(f"--load {k!r}: expected a whole number of busy processes from 0 to {MAX_LOAD}")
    return k


def _loadavg() -> tuple[float, float, float]:
    try:
        return os.getloadavg()
    except OSError:  # not available on this platform
        return (float("nan"),) * 3


@contextmanager
def cpu_load(k: int) -> Iterator[Load]:
    """Run ``k`` busy processes for the duration of the ``with`` block; always stopped after it."""
    load = Load(check_load(k), loadavg_before=_loadavg())
    procs: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(load.k):
            procs.append(subprocess.Popen([sys.executable, "-c", _BUSY], stdin=subprocess.DEVNULL,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        load.pids = [p.pid for p in procs]
        if procs:
            time.sleep(SETTLE_S)
        yield load
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        load.loadavg_after = _loadavg()
