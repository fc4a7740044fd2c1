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

from typing import Any

import pytest

MONADO = "tests/xr/monado/"
GOLDEN = MONADO + "test_golden.py"


def _unit(nodeid: str) -> str:
    path = nodeid.split("::", 1)[0]
    return path if path == GOLDEN or not path.startswith(MONADO) else "monado"


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
