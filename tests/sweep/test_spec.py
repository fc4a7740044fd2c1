"""Sweep specs: expansion into tasks, stable keys, scene overrides, and every problem at once."""

from __future__ import annotations

from pathlib import Path

import pytest

from pedvr.cli import main
from pedvr.sweep.errors import SweepSpecError
from pedvr.sweep.spec import load_spec, set_dotted
from tests.sweep.conftest import SMALL, write_spec

STEERSUITE = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "steersuite"


def test_smallest_spec_expands_to_the_product(tmp_path: Path) -> None:
    spec = load_spec(write_spec(tmp_path, SMALL.format(duration=6.0)))
    assert spec.name == "small" and len(spec.tasks) == 12
    assert spec.swept == ("responsibility",)
    combos = {(t.responsibility, t.seed) for t in spec.tasks}  # type: ignore[union-attr]
    assert combos == {(r, s) for r in (0.0, 0.5, 1.0) for s in (1, 2, 3, 4)}
    cols = spec.tasks[0].columns()
    assert {"run_key", "scene", "seed", "responsibility", "duration"} <= set(cols)
    assert cols["scene"] == "headon_corridor"
    # Keys are stable across loads and differ between tasks.
    again = load_spec(write_spec(tmp_path, SMALL.format(duration=6.0), "again.toml"))
    assert [t.key for t in spec.tasks] == [t.key for t in again.tasks]
    assert len({t.key for t in spec.tasks}) == 12
    longer = load_spec(write_spec(tmp_path, SMALL.format(duration=7.0), "longer.toml"))
    assert not {t.key for t in spec.tasks} & {t.key for t in longer.tasks}


def test_seed_range_cases_and_set(tmp_path: Path) -> None:
    spec = load_spec(
        write_spec(
            tmp_path,
            """
[sweep]
name = "mix"
scenes = ["headon_corridor"]
duration = 1.0
seeds = { from = 5, count = 3 }
[sweep.set]
steering.time_horizon = 1.5
[sweep.grid]
"steering.neighbor_dist" = [3.0, 4.0]
[[sweep.cases]]
condition = "decoupled"
[[sweep.cases]]
condition = "pedvr+g"
responsibility = 0.25
""",
        )
    )
    assert len(spec.tasks) == 2 * 2 * 3
    assert sorted({t.seed for t in spec.tasks}) == [5, 6, 7]  # type: ignore[union-attr]
    t = spec.tasks[-1]
    assert t.condition == "pedvr+g" and t.responsibility == 0.25  # type: ignore[union-attr]
    data = t.scene.data  # type: ignore[union-attr]
    assert data["steering"]["time_horizon"] == 1.5 and data["steering"]["neighbor_dist"] == 4.0
    assert t.scene.load(t.seed).steering.neighbor_dist == 4.0  # type: ignore[union-attr]
    assert set(spec.swept) == {"condition", "responsibility", "steering.neighbor_dist"}
    # Overrides change the scene's content hash, and so the key.
    assert len({x.scene.content_hash for x in spec.tasks}) == 2  # type: ignore[union-attr]


def test_dotted_keys_with_indices() -> None:
    data = {"agents": {"spawns": [{"count": 3}, {"count": 4}]}}
    assert set_dotted(data, "agents.spawns[1].count", 9) is None
    assert data["agents"]["spawns"][1]["count"] == 9
    assert (
        set_dotted(data, "agents.spawns[5].count", 1) == "agents.spawns[5] is out of range (the scene has 2)"
    )
    assert set_dotted(data, "agents.spawns.count", 1) == "agents.spawns is not a table in the scene"


def test_malformed_spec_gives_one_line_per_problem(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        """
[sweep]
name = "bad name"
scenes = ["headon_corridor", "no_such_scene"]
duration = -1
seeds = [1, 1]
colour = "red"
[sweep.grid]
responsibility = [0.0, 1.5]
speed = [1, 2]
condition = "pedvr"
""",
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    lines = err.value.problems
    expected = [
        "sweep.colour = 'red': unknown key",
        "sweep.name = 'bad name': expected letters, digits",
        "sweep.scenes[1] = 'no_such_scene': no such shipped scene",
        "sweep.seeds = [1, 1]: seed 1 is listed twice",
        "sweep.grid.condition = 'pedvr': expected a non-empty array of values to sweep",
        "sweep.grid.responsibility[1] = 1.5: expected a number in [0, 1]",
        "sweep.grid.speed = [1, 2]: unknown parameter; run options are condition, duration, responsibility, "
        "personal_space, user_walk",
        "sweep.duration = -1: must be > 0",
    ]
    assert len(lines) == len(expected)  # an unknown parameter once, not once per value (issue 25.9)
    for e in expected:
        assert any(e in ln for ln in lines), (e, lines)
    assert all(ln.startswith(f"{path}: ") for ln in lines)


def test_bad_override_gets_the_loaders_message_and_the_spec_key(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        """
[sweep]
name = "over"
scenes = ["headon_corridor"]
duration = 1.0
seeds = [1]
[sweep.grid]
"steering.time_horizon" = [1.0, -2.0]
"agents.spawns[7].count" = [1]
""",
    )
    with pytest.raises(
        SweepSpecError,
        match=r"sweep\.grid\.agents\.spawns\[7\]\.count\[0\] = 1: cannot apply to "
        r".*headon_corridor\.toml: agents\.spawns\[7\] is out of range",
    ):
        load_spec(path)
    path = write_spec(
        tmp_path,
        """
[sweep]
name = "over"
scenes = ["headon_corridor"]
duration = 1.0
seeds = [1]
[sweep.grid]
"steering.time_horizon" = [1.0, -2.0]
""",
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    assert len(err.value.problems) == 1
    assert err.value.problems[0] == (
        f"{path}: sweep.grid.steering.time_horizon[1] = -2.0: scenes/headon_corridor.toml: "
        "steering.time_horizon = -2.0: must be > 0 s"
    )


@pytest.mark.skipif(
    not (STEERSUITE / "crossing-1.xml").is_file(), reason="../shared/benchmarks/steersuite absent"
)
def test_scene_keys_do_not_apply_to_steersuite_cases(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        f"""
[sweep]
name = "ss"
scenes = ["{STEERSUITE}/crossing-*.xml"]
duration = 1.0
seeds = [1]
[sweep.set]
"steering.time_horizon" = 1.0
""",
    )
    with pytest.raises(
        SweepSpecError,
        match=r"sweep\.set\.steering\.time_horizon = 1\.0: scene keys apply to TOML "
        r"scenes; .*crossing-1\.xml is a SteerSuite case",
    ):
        load_spec(path)
    spec = load_spec(
        write_spec(
            tmp_path,
            f"""
[sweep]
name = "ss"
scenes = ["{STEERSUITE}/crossing-[12].xml"]
duration = 1.0
seeds = [1, 2]
""",
        )
    )
    assert [t.scene_name for t in spec.tasks] == ["crossing-1"] * 2 + ["crossing-2"] * 2  # type: ignore[union-attr]
    assert all(t.steerbench for t in spec.tasks)  # type: ignore[union-attr]


def test_cli_prints_each_problem_on_its_own_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write_spec(tmp_path, "[sweep]\nname = 'x'\nscenes = []\nseeds = 'all'\n")
    assert main(["sweep", str(path)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == [
        f"pedvr: error: {path}: sweep.scenes = []: expected an array of at least 1 non-empty strings",
        f"pedvr: error: {path}: sweep.seeds = 'all': expected a non-empty list of integers >= 0, "
        "or {from = 1, count = 200}",
        f"pedvr: error: {path}: sweep.duration = <missing>: required number > 0 (simulated seconds per run)",
    ]
    assert main(["sweep", "report"]) == 2
    assert "give the sweep's output folder" in capsys.readouterr().err
    assert main(["sweep", "report", str(tmp_path), "--resume"]) == 2
    assert "--resume applies to running a sweep" in capsys.readouterr().err
    assert main(["sweep", "report", str(tmp_path)]) == 2
    assert f"{tmp_path}: no runs.parquet here" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["responsibility", "conditions", "steerbench", "dryrun"])
def test_shipped_specs_load(name: str) -> None:
    if name == "steerbench" and not (STEERSUITE / "crossing-1.xml").is_file():
        pytest.skip("../shared/benchmarks/steersuite absent")
    spec = load_spec(Path(__file__).resolve().parents[2] / "sweeps" / f"{name}.toml")
    expected = {"responsibility": 800, "conditions": 7 * 3 * 20, "steerbench": 34 * 5, "dryrun": 24}[name]
    assert len(spec.tasks) == expected


def test_a_bad_override_crossed_with_other_axes_is_reported_once(tmp_path: Path) -> None:
    path = write_spec(
        tmp_path,
        """
[sweep]
name = "once"
scenes = ["headon_corridor"]
duration = 1.0
seeds = [1]
[sweep.grid]
"gaze.distance" = [0.0]
responsibility = [0.0, 0.5, 1.0]
""",
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    assert err.value.problems == [
        f"{path}: sweep.grid.gaze.distance[0] = 0.0: scenes/headon_corridor.toml: "
        "gaze.distance = 0.0: must be > 0 m"
    ]


def test_without_the_extra_one_line_says_how_to_install_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "distributed", None)  # as if dask.distributed were not installed
    assert main(["sweep", str(write_spec(tmp_path, SMALL.format(duration=1.0)))]) == 2
    assert capsys.readouterr().err == (
        "pedvr: error: pedvr sweep needs the sweep extra (distributed is missing): pip install -e '.[sweep]'\n"
    )


def test_flatten_metrics() -> None:
    import numpy as np

    from pedvr.sweep.task import flatten

    got = flatten(
        {
            "a": 1,
            "b": {"c": np.float64(2.5), "d": {"e": None}},
            "f": [1, {"g": 2}],
            "h": float("nan"),
            "i": np.int64(3),
            "j": np.float64("inf"),
        }
    )
    assert got == {"a": 1, "b.c": 2.5, "b.d.e": None, "f": '[1, {"g": 2}]', "h": None, "i": 3, "j": None}
    assert type(got["i"]) is int


def test_personal_space_and_user_walk_are_run_options(tmp_path: Path) -> None:
    """Issue 25.9: `pedvr run --personal-space` exists, the spec refused `personal_space` as unknown."""
    from pedvr.sweep.task import execute

    spec = load_spec(
        write_spec(
            tmp_path,
            """
[sweep]
name = "margin"
scenes = ["headon_corridor"]
duration = 0.3
seeds = [1]
[sweep.set]
user_walk = "reactive"
[sweep.grid]
personal_space = [0.0, 0.6]
""",
        )
    )
    assert spec.swept == ("personal_space",)
    assert [(t.personal_space, t.user_walk) for t in spec.tasks] == [(0.0, "reactive"), (0.6, "reactive")]  # type: ignore[union-attr]
    assert len({t.key for t in spec.tasks}) == 2
    assert spec.tasks[1].columns()["personal_space"] == 0.6
    result = execute(spec.tasks[1])
    assert result["status"] == "ok", result["error"]
    assert result["metrics"]["personal_space_m"] == 0.6 and result["metrics"]["user_walk"] == "reactive"
    bad = write_spec(
        tmp_path,
        SMALL.format(duration=1.0).replace("responsibility = [0.0, 0.5, 1.0]",
                                           'personal_space = [0.3, 2.5]\nuser_walk = ["zigzag"]'),
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(bad)
    assert [ln.split(": ", 1)[1] for ln in err.value.problems] == [
        "sweep.grid.personal_space[1] = 2.5: expected a number in [0, 2] (metres agents keep from the user)",
        "sweep.grid.user_walk[0] = 'zigzag': expected one of 'straight', 'reactive'",
    ]


@pytest.mark.parametrize("grid", ["[sweep.grid]\n", "[sweep.grid]\n[sweep.grid.steering]\n"])
def test_an_empty_grid_is_an_error_not_one_silent_run(tmp_path: Path, grid: str) -> None:
    """Issue 25.9: an empty [sweep.grid] ran each scene once, silently."""
    path = write_spec(
        tmp_path, '[sweep]\nname = "e"\nscenes = ["headon_corridor"]\nduration = 1.0\nseeds = [1]\n' + grid
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    assert len(err.value.problems) == 1
    assert err.value.problems[0].startswith(f"{path}: sweep.grid = ")
    assert err.value.problems[0].endswith(
        ": empty: give each parameter to sweep a list of values, or leave [sweep.grid] out"
    )


def test_a_missing_scene_path_says_where_it_looked(tmp_path: Path) -> None:
    """Issue 25.9: a missing absolute path said "(relative to the spec file)"."""
    path = write_spec(
        tmp_path,
        f"""
[sweep]
name = "paths"
scenes = ["{tmp_path}/absent.toml", "absent.xml", "{tmp_path}/none-*.xml", "sub/none-*.toml"]
duration = 1.0
seeds = [1]
""",
    )
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    assert [ln.split(": ", 1)[1] for ln in err.value.problems] == [
        f"sweep.scenes[0] = '{tmp_path}/absent.toml': no such scene file",
        f"sweep.scenes[1] = 'absent.xml': no such scene file (paths are relative to the spec file: "
        f"{tmp_path.resolve()}/absent.xml)",
        f"sweep.scenes[2] = '{tmp_path}/none-*.xml': the glob matches no .toml or .xml file",
        f"sweep.scenes[3] = 'sub/none-*.toml': the glob matches no .toml or .xml file (paths are relative to the "
        f"spec file: {tmp_path.resolve()}/sub/none-*.toml)",
    ]


@pytest.mark.parametrize(
    "seeds, message",
    [
        ("[-3]", "sweep.seeds = [-3]: expected a non-empty list of integers >= 0, or {from = 1, count = 200}"),
        ("{ from = -3, count = 2 }", "sweep.seeds.from = -3: must be >= 0"),
    ],
)
def test_negative_seeds_are_one_line(tmp_path: Path, seeds: str, message: str) -> None:
    """Issue 24.2: numpy's generators take no negative seed; a spec says so in one line, as `pedvr run`."""
    path = write_spec(tmp_path, SMALL.format(duration=1.0).replace("[1, 2, 3, 4]", seeds))
    with pytest.raises(SweepSpecError) as err:
        load_spec(path)
    assert err.value.problems == [f"{path}: {message}"]
