"""``pedvr bench doors`` runs what it says (the figures are benchmarks, not asserted here)."""

from __future__ import annotations

import json

import pytest

from pedvr.cli import main
from pedvr.errors import UsageError
from pedvr.etiquette.bench import building_scene
from pedvr.sim import PHASES


def test_building_spreads_the_pedestrians_over_its_four_rooms() -> None:
    assert [s.count for s in building_scene(16).spawns] == [4, 4, 4, 4]
    assert [s.count for s in building_scene(66).spawns] == [17, 17, 16, 16]
    assert [s.count for s in building_scene(2).spawns] == [1, 1]
    with pytest.raises(UsageError, match=r"--agents 0: expected a whole number of pedestrians >= 1"):
        building_scene(0)


def test_cli_bench_doors_json_and_bad_flags(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "doors", "--agents", "8", "--steps", "4", "--warmup", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["agents"] == 8 and out["steps"] == 4 and out["scene"] == "door_building"
    assert set(out["phase_ms_mean"]) == set(PHASES) and 0 < out["step_ms_p50"] <= out["step_ms_p95"]
    assert out["etiquette_ms_mean"] > 0 and out["overlaps_over_1cm"] == 0
    assert main(["bench", "doors", "--agents", "8", "--warmup", "-1"]) == 2
    assert capsys.readouterr().err.strip() == "pedvr: error: --warmup -1: expected a whole number >= 0"
