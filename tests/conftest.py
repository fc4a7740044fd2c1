"""How the suite is shared out when it runs on pytest-xdist (the README's test command runs one worker
per core; see pyproject.toml).

Each test file is one unit, run whole by one worker, so a module's fixtures (the eight door_single_flow
runs of tests/etiquette/test_door_flow.py, say) are computed once. The tests against Monado are one unit
together (but for the golden test, below): they share the chroot's numba cache, which the cold-start
test, first, fills (in a first try that split them between two workers, all 21 errored). That unit is the
longest (several minutes with cold caches), so it goes first.

(pytest-xdist's own ``--dist loadgroup`` would do this with ``xdist_group`` marks, but with pytest 9 it
groups nothing: checked with pytest 9.2 and pytest-xdist 3.8, a module's ``pytestmark`` group was split
between two workers. Hence a scheduler of our own, through xdist's hook.)
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import pytest

MONADO = "tests/xr/monado/"
GOLDEN = MONADO + "test_golden.py"


def _unit(nodeid: str) -> str:
    path = nodeid.split("::", 1)[0]
    return path if path == GOLDEN or not path.startswith(MONADO) else "monado"


# The host's kernels, compiled once for every worker. With cold caches each worker's first host test
# compiled the kernels of a step, and the two workers compiled the same ones at the same time: the
# second worker's first host file (tests/behavior/test_guide.py, 306 s) needs nothing the first
# one's (tests/behavior/test_bench.py, 689 s) did not compile: 4 s after it, measured alone.
PREPARED = ("antipodal_circle", "door_double")  # what test_bench and test_guide compile, and more
_prepared = False


def _prepare_host_kernels() -> None:
    """Before a worker's first host test: ``pedvr prepare`` the scenes in :data:`PREPARED` under a lock
    in numba's cache folder, when the cache is cold (:func:`pedvr.warmup.cold`). The first worker there
    compiles, in two processes (``pedvr prepare`` steps the first scene in a second one,
    :mod:`pedvr.warmup`); a worker that comes while it does waits, then finds the cache warm and goes
    on (before, it compiled the same kernels again, beside the first). The compile runs at a lower
    priority (nice 10), so that a test measuring frame times beside it (the cold-start test, in the
    chroot) keeps the CPU it needs. A prepare that fails is said once as a warning, and the tests
    compile what they need themselves, as without this."""
    global _prepared
    if _prepared:
        return
    _prepared = True
    from pedvr import warmup

    cache = os.environ.get("NUMBA_CACHE_DIR")  # set by `import pedvr` (pedvr.numba_cache_dir)
    if not cache or not warmup.cold():
        return
    Path(cache).mkdir(parents=True, exist_ok=True)
    with open(Path(cache) / "tests-prepare.lock", "a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not warmup.cold():
            return  # another worker prepared while this one waited
        done = subprocess.run(["nice", "-n", "10", sys.executable, "-m", "pedvr", "prepare", *PREPARED],
                              capture_output=True, text=True, stdin=subprocess.DEVNULL)
        if done.returncode != 0:
            warnings.warn(f"pedvr prepare {' '.join(PREPARED)} failed (rc {done.returncode}); the tests compile "
                          f"their kernels themselves: {done.stderr.strip()[-500:]}", stacklevel=1)


@pytest.fixture(autouse=True)
def _host_kernels(request: pytest.FixtureRequest) -> None:
    """:func:`_prepare_host_kernels` before the first test on the host (the Monado tests but the
    golden one run pedvr inside the chroot, with its own cache)."""
    if _unit(request.node.nodeid) != "monado":
        _prepare_host_kernels()


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    from xdist.scheduler import LoadScopeScheduling

    class FileScheduling(LoadScopeScheduling):
        """A file per unit, the Monado tests but the golden one a unit, handed out in collection order."""

        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid)

    config.option.loadscopereorder = False  # keep _order's order
    return FileScheduling(config, log)


def _order(item: pytest.Item) -> int:
    """The Monado unit first, cold start first in it (it fills the chroot's numba cache the others
    use); the golden test last of all. That one also steps and draws on the host: run beside the
    other worker's first tests, it compiled the same kernels as they did at the same time (218-298 s
    on this 2-core machine, against 31 s for its Monado captures). Its service waits for any other
    (:class:`tests.xr.monado.chroot.Service` holds a lock), however the workers are placed."""
    path = item.nodeid.split("::", 1)[0]
    if path == GOLDEN:
        return 9
    if path.startswith(MONADO):
        return 0 if path.endswith("test_cold_start.py") else 1
    return 2


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=_order)  # stable: file order otherwise
