"""``pedvr bench place``: it runs, plans every query, reports the parts (speed goals live in the bench)."""

from __future__ import annotations

import json

from pedvr.cli import main
from pedvr.demonstrator.bench import run_place_bench


def test_place_bench_reports_planning_and_step_times() -> None:
    r = run_place_bench("place_table", queries=6, seconds=2.0)
    assert r["queries"] == 6 and r["placed"] == 6 and r["candidates_per_query"] == 72.0
    for part in ("search", "path", "hand", "plan", "slice", "sim_step", "sim_base_step"):
        assert 0.0 < r[f"{part}_ms_p50"] <= r[f"{part}_ms_p95"] <= r[f"{part}_ms_max"]
    # the whole plan is its parts; a tick's slice is a part of the search
    assert r["plan_ms_mean"] >= r["search_ms_mean"] >= r["slice_ms_mean"]
    assert r["sim_demonstrations"] >= 1


def test_place_bench_cli_json(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["bench", "place", "--scene", "gallery", "--queries", "3", "--seconds", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)  # one scene: one object
    assert out["scene"] == "gallery" and out["placed"] == 3


def test_place_bench_rejects_an_unknown_scene(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["bench", "place", "--scene", "nowhere"]) == 2
    assert "invalid choice: 'nowhere'" in capsys.readouterr().err
