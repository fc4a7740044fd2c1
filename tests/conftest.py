"""How the suite is shared out when it runs on pytest-xdist (the README's test command runs one worker
per core, ``--dist loadgroup``; see pyproject.toml).

Each test file is one unit, run whole by one worker, so a module's fixtures (the eight door_single_flow
runs of tests/etiquette/test_door_flow.py, say) are computed once. The tests against Monado are one unit
together, in file order: they share the chroot's bind mount and numba cache (the cold-start test, first,
fills it), and one monado-service runs at a time. That unit is the longest (about a quarter of the suite
with cold caches), so it goes first.
"""

from __future__ import annotations

from pathlib import Path

import pytest

MONADO = Path(__file__).parent / "xr" / "monado"


def _group(item: pytest.Item) -> str:
    path = Path(str(item.fspath))
    return "monado" if MONADO in path.parents else path.relative_to(Path(__file__).parent).as_posix()


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        if item.get_closest_marker("xdist_group") is None:
            item.add_marker(pytest.mark.xdist_group(_group(item)))
    items.sort(key=lambda item: _group(item) != "monado")  # stable: file order otherwise
