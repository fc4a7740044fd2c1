"""Shared fixtures: one 2-worker LocalCluster for the module's Dask tests, and tiny specs.

The cluster is closed at the end of the session (no scheduler or worker
process is left behind); the tests keep runs short (headon_corridor, under a
simulated second) so the whole folder stays fast on 2 cores.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("distributed", reason="the sweep extra is not installed: pip install -e '.[sweep]'")
pytest.importorskip("pyarrow", reason="the sweep extra is not installed: pip install -e '.[sweep]'")

DATA = Path(__file__).resolve().parent / "data"

SMALL = """
[sweep]
name = "small"
scenes = ["headon_corridor"]
duration = {duration}
seeds = [1, 2, 3, 4]
[sweep.grid]
responsibility = [0.0, 0.5, 1.0]
"""


def write_spec(folder: Path, text: str, name: str = "spec.toml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


@pytest.fixture(scope="session")
def cluster_client() -> Iterator[Any]:
    """A 2-worker LocalCluster started as ``pedvr sweep --workers 2`` starts it."""
    from pedvr.sweep.runner import start_local_cluster

    client, own = start_local_cluster(2)
    try:
        yield client
    finally:
        for thing in reversed(own):
            thing.close()
