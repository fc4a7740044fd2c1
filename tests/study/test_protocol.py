"""Protocols are validated at load: every problem at once, naming file, key, value and expectation."""

from __future__ import annotations

from pathlib import Path

import pytest

from pedvr.errors import UsageError
from pedvr.study.errors import ProtocolError
from pedvr.study.protocol import load_protocol, participant_number

ROOT = Path(__file__).resolve().parents[2]
QDIR = ROOT / "user_study" / "questionnaires"


def test_shipped_protocol_matches_the_paper() -> None:
    p = load_protocol(ROOT / "user_study" / "pedvr_replication.toml")
    assert p.conditions == ("decoupled", "pedvr", "pedvr+g")
    assert p.comparisons == (("pedvr+g", "decoupled"), ("pedvr", "decoupled"), ("pedvr+g", "pedvr"))
    kinds = [(s.id, s.kind) for s in p.steps]
    assert [k for _, k in kinds] == ["instructions", "questionnaire", "questionnaire", "questionnaire", "trial",
                                     "blocks", "sweep", "questionnaire", "questionnaire", "instructions"]
    steps = {s.id: s for s in p.steps}
    assert steps["demographics"].optional
    assert [b.scene_name for b in steps["scenarios"].blocks] == ["antipodal_circle", "bidirectional_flow"]
    assert all(b.after_block == "social_presence" for b in steps["scenarios"].blocks)
    assert steps["corridor"].values == (0.0, 0.25, 0.5, 1.0) and steps["corridor"].order == "random"
    assert steps["ssq_pre"].questionnaire == steps["ssq_post"].questionnaire == "ssq"
    assert steps["training"].scene_name == "training"
    assert len(p.content_hash) == 16


def _write(tmp_path: Path, body: str) -> Path:
    f = tmp_path / "p.toml"
    f.write_text(f'[study]\nquestionnaire_dir = "{QDIR}"\n' + body)
    return f


def test_malformed_protocol_reports_every_problem(tmp_path: Path) -> None:
    f = _write(tmp_path, """
name = "bad study"
seed = -1
conditions = ["pedvr", "fast"]
comparisons = ["pedvr/pedvr"]

[[steps]]
id = "a"
kind = "questionnaire"
questionnaire = "nope"

[[steps]]
id = "a"
kind = "trial"
scene = "no_such_scene"
condition = "pedvr"
time_limit_s = -5

[[steps]]
id = "c"
kind = "sweep"
scene = "headon_corridor"
condition = "pedvr"
responsibility = [0.0, 1.5]
order = "sideways"
time_limit_s = 10

[[steps]]
id = "d"
kind = "dance"

[[steps]]
id = "e"
kind = "blocks"
order = "fixed"
  [[steps.blocks]]
  id = "b1"
  scene = "antipodal_circle"
  time_limit_s = 10
  condition_order = "fixed"
  after_block = "ssq"
  after_each_trial = "social_presence"
""")
    with pytest.raises(ProtocolError) as exc:
        load_protocol(f)
    got = exc.value.problems
    expected = [
        "study.name = 'bad study': expected letters, digits, _ . -",
        "study.seed = -1: must be >= 0",
        "study.conditions[1] = 'fast': expected one of decoupled, pedvr, pedvr+g",
        "study.comparisons[0] = 'pedvr/pedvr': expected \"left/right\": two different study.conditions",
        "steps[0].questionnaire = 'nope': no questionnaire file",
        "steps[1].id = 'a': duplicate step id",
        "steps[1].scene = 'no_such_scene': no such scene",
        "steps[1].time_limit_s = -5: must be > 0 s",
        "steps[2].responsibility = [0.0, 1.5]: required array of shares in [0, 1]",
        "steps[2].order = 'sideways': expected one of 'balanced_latin_square', 'random', 'fixed'",
        "steps[3].kind = 'dance': expected one of",
        "steps[4].blocks[0].after_each_trial = 'social_presence': is a pairwise questionnaire; expected likert or form",
    ]
    for e in expected:
        assert any(line.startswith(f"{f}: {e}") for line in got), (e, got)
    assert len(got) >= len(expected)


def test_protocol_scene_errors_are_reported_with_the_step(tmp_path: Path) -> None:
    scene = tmp_path / "broken.toml"
    scene.write_text('[scene]\nname = "x"\nseed = 1\nduration = -1\n')
    f = _write(tmp_path, """
name = "s"
seed = 1
conditions = ["pedvr"]
[[steps]]
id = "t"
kind = "trial"
scene = "broken.toml"
condition = "pedvr"
time_limit_s = 5
""")
    with pytest.raises(ProtocolError, match=r"p\.toml: steps\[0\]\.scene = 'broken\.toml': scene problem: .*"
                                            r"scene\.duration = -1: must be > 0 s"):
        load_protocol(f)


def test_missing_required_keys_never_default(tmp_path: Path) -> None:
    f = _write(tmp_path, "[[steps]]\nid = \"x\"\nkind = \"instructions\"\n")
    with pytest.raises(ProtocolError) as exc:
        load_protocol(f)
    assert f"{f}: study.name = <missing>: required string" in exc.value.problems
    assert f"{f}: study.seed = <missing>: required integer >= 0" in exc.value.problems
    assert f"{f}: steps[0].text = <missing>: required string" in exc.value.problems


def test_not_toml_and_missing_file(tmp_path: Path) -> None:
    f = tmp_path / "p.toml"
    f.write_text("[study\n")
    with pytest.raises(ProtocolError, match=r"p\.toml: not valid TOML"):
        load_protocol(f)
    with pytest.raises(ProtocolError, match=r"nowhere\.toml: no such protocol file"):
        load_protocol(tmp_path / "nowhere.toml")


@pytest.mark.parametrize("pid, number", [("P07", 7), ("S-12", 12), ("SIM03", 3)])
def test_participant_number(pid: str, number: int) -> None:
    assert participant_number(pid) == number


def test_participant_without_number_is_refused() -> None:
    with pytest.raises(UsageError, match=r"participant 'bob': expected an id ending in a number >= 1, like P07"):
        participant_number("bob")
