"""How the suite is shared out when it runs on pytest-xdist (the README's test command runs one worker
per core; see pyproject.toml).

Each test file is one unit, run whole by one worker, so a module's fixtures (the eight door_single_flow
runs of tests/etiquette/test_door_flow.py, say) are computed once. The tests against Monado are one unit
together, in file order: they share the chroot's bind mount and numba cache (the cold-start test, first,
fills it), and one monado-service runs at a time (run side by side on two workers, every one of them
errored). That unit is the longest (several minutes with cold caches), so it goes first.

(pytest-xdist's own ``--dist loadgroup`` would do this with ``xdist_group`` marks, but with pytest 9 it
groups nothing: checked with pytest 9.2 and pytest-xdist 3.8, a module's ``pytestmark`` group was split
between two workers. Hence a scheduler of our own, through xdist's hook.)
"""

from __future__ import annotations

from typing import Any

import pytest

MONADO = "tests/xr/monado/"


def _unit(nodeid: str) -> str:
    path = nodeid.split("::", 1)[0]
    return "monado" if path.startswith(MONADO) else path


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    from xdist.scheduler import LoadScopeScheduling

    class FileScheduling(LoadScopeScheduling):  # type: ignore[misc]
        """A file per unit, the Monado tests one unit, units handed out in collection order."""

        def _split_scope(self, nodeid: str) -> str:
            return _unit(nodeid)

    config.option.loadscopereorder = False  # keep the order below: the Monado unit first
    return FileScheduling(config, log)


# The Monado unit's order: the cold-start test fills the chroot's numba cache the others use; the
# golden test also steps and draws on the host, so it goes last, once the other worker has filled the
# host's numba cache (run third, it compiled the same kernels as the other worker at the same time:
# 298 s on a 2-core machine, against 28 s for its Monado captures).
_MONADO_ORDER = ("test_cold_start.py", "test_runtime.py")


def _order(item: pytest.Item) -> tuple[int, int]:
    if not item.nodeid.startswith(MONADO):
        return (1, 0)
    name = item.nodeid[len(MONADO):].split("::", 1)[0]
    return (0, _MONADO_ORDER.index(name) if name in _MONADO_ORDER else len(_MONADO_ORDER))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    items.sort(key=_order)  # stable: file order otherwise
