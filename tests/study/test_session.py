"""Sessions end to end: a simulated 6-participant study, the console keys, resume, refusal, export."""

from __future__ import annotations

import io
import itertools
import sqlite3
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pedvr.study.analysis import analyze
from pedvr.study.analysis import corridor_trajectories as analyze_corridor
from pedvr.study.cli import build_parser, run_study_command
from pedvr.study.console import ExperimenterConsole, NoKeys, ScriptedKeys
from pedvr.study.errors import ParticipantExistsError, StudyStoreError
from pedvr.study.export import export_study
from pedvr.study.presenter import SimulatedParticipant, TerminalParticipant
from pedvr.study.protocol import load_protocol
from pedvr.study.session import Session
from pedvr.study.store import StudyStore

from .conftest import shortened_protocol


def _session(protocol_path: Path, store: StudyStore, pid: str, *, keys: object = None, resume: bool = False,
             participant: object = None) -> tuple[Session, io.StringIO]:
    p = load_protocol(protocol_path)
    from pedvr.study.protocol import participant_number

    out = io.StringIO()
    console = ExperimenterConsole(out=out, keys=keys or NoKeys(), live=False)
    who = participant or SimulatedParticipant(seed=p.seed, number=participant_number(pid))
    return Session(protocol=p, store=store, participant_id=pid, participant=who, console=console,
                   backend="headless", resume=resume, simulated=True), out


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six simulated participants through the (shortened) replication protocol, headless."""
    folder = tmp_path_factory.mktemp("study")
    proto = shortened_protocol(folder)
    db = folder / "study.sqlite"
    with StudyStore(db) as store:
        for k in range(1, 7):
            s, _ = _session(proto, store, f"P{k:02d}")
            assert s.run().status == "finished"
    return db


def _q(db: Path, sql: str, params: tuple = ()) -> list[tuple]:
    with sqlite3.connect(db) as c:
        return c.execute(sql, params).fetchall()


def test_simulated_study_records_everything(study: Path) -> None:
    assert _q(study, "SELECT COUNT(*), SUM(status = 'finished') FROM participants") == [(6, 6)]
    assert _q(study, "SELECT COUNT(*) FROM steps WHERE status != 'done'") == [(0,)]
    sess = _q(study, "SELECT software_version, protocol_hash, seed, backend, started_utc, status FROM sessions")
    assert len(sess) == 6 and all(r[3] == "headless" and r[5] == "finished" and r[4].endswith("Z") for r in sess)
    # per participant: 1 training + 6 block trials + 4 corridor trials
    assert _q(study, "SELECT participant, COUNT(*) FROM trials GROUP BY participant") == \
        [(f"P{k:02d}", 11) for k in range(1, 7)]
    assert _q(study, "SELECT COUNT(*) FROM trials WHERE outcome NOT IN ('time_limit', 'reached_last_sphere')") == [(0,)]
    # answers: consent 1 + demographics 2 + SSQ 16 x 2 + pairwise 8 x 3 x 2 + feedback 1 = 84
    assert _q(study, "SELECT participant, COUNT(*) FROM answers GROUP BY participant") == \
        [(f"P{k:02d}", 84) for k in range(1, 7)]
    # samples at frame rate: one per step of 1/90 s plus the initial frame, head pose at eye height
    frames, n = _q(study, "SELECT frames, (SELECT COUNT(*) FROM samples s WHERE s.trial_id = t.trial_id) FROM trials t "
                          "WHERE design = 'sweep' LIMIT 1")[0]
    assert frames == n == 46
    hz, qw, qz = _q(study, "SELECT head_z, head_qw, head_qz FROM samples LIMIT 1")[0]
    assert hz == 1.6 and qw**2 + qz**2 == pytest.approx(1.0)
    # every agent every frame: the corridor has the user and one agent
    assert _q(study, "SELECT COUNT(*) FROM agent_samples a JOIN trials t USING (trial_id) WHERE t.design = 'sweep'") == \
        [(24 * 46 * 2,)]
    t_mono = [r[0] for r in _q(study, "SELECT t_mono FROM samples WHERE trial_id = 2 ORDER BY frame")]
    assert all(b >= a for a, b in itertools.pairwise(t_mono))


def test_simulated_study_counterbalancing_is_recorded(study: Path) -> None:
    rows = _q(study, "SELECT participant, block, condition, label, trial_order FROM trials WHERE design = 'block' "
                     "ORDER BY trial_id")
    orders: dict[str, Counter] = {}
    for (_pid, block), grp in itertools.groupby(rows, key=lambda r: (r[0], r[1])):
        grp = list(grp)
        assert [r[3] for r in grp] == ["A", "B", "C"] and [r[4] for r in grp] == [1, 2, 3]
        orders.setdefault(block, Counter())[tuple(r[2] for r in grp)] += 1
    for block, c in orders.items():
        assert len(c) == 6 and set(c.values()) == {1}, block  # all 6 orders, once each
    flips = _q(study, "SELECT comparison, SUM(flipped), COUNT(*) FROM answers WHERE comparison IS NOT NULL "
                      "GROUP BY comparison")
    for comparison, flipped, total in flips:
        assert 0 < flipped < total, comparison
    # raw as shown, recoded to the fixed orientation
    bad = _q(study, "SELECT COUNT(*) FROM answers WHERE comparison IS NOT NULL AND "
                    "recoded_value != CASE WHEN flipped = 1 THEN 8 - raw_value ELSE raw_value END")
    assert bad == [(0,)]
    labels = _q(study, "SELECT raw_value, raw_label FROM answers WHERE questionnaire = 'social_presence' AND raw_value = 1 "
                       "LIMIT 1")
    assert labels == [(1.0, "Left much better")]


def test_analysis_reads_the_study_database(study: Path, tmp_path: Path) -> None:
    res = analyze(db=study)
    assert res["n_participants"] == 6
    for scen in ("antipodal_circle", "bidirectional_flow"):
        s = res["scenarios"][scen]
        assert list(s["comparisons"]) == ["pedvr+g/decoupled", "pedvr/decoupled", "pedvr+g/pedvr"]
        assert s["n"] == 6 and s["rm_anova"]["df1"] == 2
        # the simulated participants prefer PedVR+G most strongly over Decoupled
        assert s["comparisons"]["pedvr+g/decoupled"]["mean"] < s["comparisons"]["pedvr/decoupled"]["mean"] < 4
    assert res["ssq"]["summary"]["change"]["total"]["n"] == 6
    cor = res["corridor"]["by_responsibility"]
    assert sorted(cor) == ["0", "0.25", "0.5", "1"] and all(b["n"] == 6 for b in cor.values())
    out = io.StringIO()
    args = build_parser().parse_args(["analyze", str(study), "--report", str(tmp_path / "rep")])
    assert run_study_command(args, stdout=out) == 0
    assert "RM-ANOVA: F(" in out.getvalue()
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "## Head-on corridor by responsibility" in md and "## Simulator sickness" in md
    assert (tmp_path / "rep" / "corridor_trajectories.svg").is_file()


def test_corridor_trajectories_by_responsibility(tmp_path: Path) -> None:
    db = tmp_path / "corridor.sqlite"
    with StudyStore(db) as store:
        s, _ = _session(Path(__file__).resolve().parent / "data" / "corridor.toml", store, "P01",
                        participant=SimulatedParticipant(seed=5, number=1, walk="straight"))
        assert s.run().status == "finished"
    cor = analyze_corridor(db)
    by = cor["by_responsibility"]
    assert sorted(by) == ["0", "0.25", "0.5", "1"] and all(b["n"] == 1 for b in by.values())
    for t in cor["trials"]:
        assert t["agent_id"] == 1 and 0.0 < t["min_distance_m"] < 11.0
    # the scripted user walks straight at the agent and never moves aside, so if anyone gives way
    # it is the agent; with the whole share of avoidance (1) it does
    for b in by.values():
        assert b["user_lateral_deviation_m"]["mean"] == pytest.approx(0.0, abs=1e-9)
        assert b["gave_way"]["user"] == b["gave_way"]["both"] == 0
    assert by["1"]["gave_way"]["agent"] == 1
    assert by["0"]["min_distance_m"]["mean"] <= by["1"]["min_distance_m"]["mean"]
    assert len(cor["trajectories"]) == 4 and len(cor["trajectories"][0]["user"]) == 541


def test_simulated_participant_steps_aside_by_what_the_agent_leaves(tmp_path: Path) -> None:
    """The default simulated participant reacts like a person (issue 10): at ρ = 0 it gives
    way itself, at ρ = 1 the agent does and the participant walks on."""
    db = tmp_path / "corridor.sqlite"
    with StudyStore(db) as store:
        s, _ = _session(Path(__file__).resolve().parent / "data" / "corridor.toml", store, "P01")
        assert s.run().status == "finished"
    by = analyze_corridor(db)["by_responsibility"]
    assert by["0"]["user_lateral_deviation_m"]["mean"] > 0.2
    assert by["1"]["user_lateral_deviation_m"]["mean"] < 0.05


def test_export_round_trips_through_pandas(study: Path, tmp_path: Path) -> None:
    nasty = 'tab\there, comma, "quoted"\nsecond line; \'single\''
    with StudyStore(study) as store:
        store.db.execute("UPDATE answers SET text = ? WHERE questionnaire = 'feedback' AND participant = 'P01'",
                         (nasty,))
        written = export_study(study, out=tmp_path / "x")
        for table in ("participants", "sessions", "steps", "trials", "answers", "events", "contacts", "samples"):
            want = pd.read_sql_query(f"SELECT * FROM {table}", store.db)
            got = pd.read_csv(tmp_path / "x" / f"{table}.tsv", sep="\t")
            # SQL NULL reads as None from sqlite and as NaN from the file: the same missing value
            want = want.astype(object).where(want.notna(), np.nan).infer_objects()
            if table == "samples":  # the export adds whether the trial was cut off and run again
                assert (got.pop("interrupted") == 0).all()
            pd.testing.assert_frame_equal(got, want, check_dtype=False, obj=table)
        store.db.execute("UPDATE answers SET text = NULL WHERE questionnaire = 'feedback' AND participant = 'P01'")
    answers = pd.read_csv(tmp_path / "x" / "answers.tsv", sep="\t")
    assert answers.loc[(answers.participant == "P01") & (answers.questionnaire == "feedback"), "text"].item() == nasty
    traj = sorted((tmp_path / "x" / "trajectories").glob("trial-*.tsv"))
    assert len(traj) == 66 and tmp_path / "x" / "responses.csv" in written
    t = pd.read_csv(traj[0], sep="\t")
    assert list(t.columns) == ["trial_id", "frame", "sim_t", "agent_id", "is_user", "x", "y", "heading", "interrupted"]
    # the long-format responses file feeds the CSV form of analyze, with the same numbers
    from_csv = analyze(responses=tmp_path / "x" / "responses.csv")
    from_db = analyze(db=study)
    a = from_csv["scenarios"]["antipodal_circle"]["rm_anova"]
    assert a["F"] == pytest.approx(from_db["scenarios"]["antipodal_circle"]["rm_anova"]["F"])


def test_existing_participant_needs_resume(study: Path) -> None:
    with StudyStore(study) as store:
        s, _ = _session(_proto_of(study), store, "P03")
        with pytest.raises(ParticipantExistsError, match=r"participant P03 already exists in .*study\.sqlite "
                                                         r"\(status finished\); use --resume"):
            s.run()
        s, _ = _session(_proto_of(study), store, "P99", resume=True)
        with pytest.raises(StudyStoreError, match=r"participant P99 has no session in .* to resume; start without"):
            s.run()
        s, _ = _session(_proto_of(study), store, "Q3")
        with pytest.raises(ParticipantExistsError, match=r"participant Q3: number 3 is already used by P03"):
            s.run()
        s, _ = _session(_proto_of(study), store, "P03", resume=True)
        assert s.run().status == "already_finished"


def _proto_of(db: Path) -> Path:
    return db.parent / "pedvr_replication_short.toml"


def test_console_keys_skip_pause_abort_and_resume(tmp_path: Path, mini_protocol: Path) -> None:
    db = tmp_path / "k.sqlite"
    keys = ScriptedKeys(["s", "participant already briefed", None,  # skip step 1 (instructions)
                         "p", "x", "p", None,  # pause during the SSQ, a stray key, resume
                         "a", "no", None,  # abort cancelled
                         "a", "yes"])  # abort
    with StudyStore(db) as store:
        s, out = _session(mini_protocol, store, "P01", keys=keys)
        r = s.run()
        assert r.status == "aborted" and "continue with --resume" in r.message
        text = out.getvalue()
        assert "skipping: participant already briefed" in text and "paused at" in text and "abort cancelled" in text
        assert keys.prompts[0].startswith("skip this step: reason")
        steps = store.steps("P01")
        assert (steps[0].status, steps[0].reason) == ("skipped", "participant already briefed")
        assert steps[1].status == "pending"
        assert [e["kind"] for e in store.query("SELECT kind FROM events ORDER BY event_id")] == \
            ["skip", "pause", "resume", "abort"]
        assert store.query("SELECT COUNT(*) AS n FROM answers")[0]["n"] == 3  # SSQ items 1..3 answered
        assert store.query("SELECT status FROM sessions")[0]["status"] == "aborted"
        # without --resume: refused; with it: continues at SSQ item 4 and finishes
        s, _ = _session(mini_protocol, store, "P01")
        with pytest.raises(ParticipantExistsError):
            s.run()
        s, out = _session(mini_protocol, store, "P01", resume=True)
        r = s.run()
        assert r.status == "finished"
        assert "resuming at step 2/" in out.getvalue()
        n_items = store.query("SELECT COUNT(*) AS n FROM answers WHERE questionnaire = 'ssq'")[0]["n"]
        assert n_items == 16
        # mini: 3 block trials with a likert after each, then the pairwise questionnaire, 2 sweep trials
        assert store.query("SELECT COUNT(*) AS n FROM answers WHERE questionnaire = 'realism_rating'")[0]["n"] == 9
        rev = store.query("SELECT raw_value, recoded_value FROM answers WHERE item = 'robotic'")
        assert all(r["recoded_value"] == 8 - r["raw_value"] for r in rev)
        assert store.query("SELECT COUNT(*) AS n FROM trials")[0]["n"] == 5


def test_skip_during_a_trial_records_the_reason(tmp_path: Path, mini_protocol: Path) -> None:
    # polls: step 1 check, step 2 check + 15 between SSQ items, step 3 check, then each trial frame
    keys = ScriptedKeys([None] * 18 + [None] * 5 + ["s", "headset slipped"])
    with StudyStore(tmp_path / "t.sqlite") as store:
        s, _ = _session(mini_protocol, store, "P02", keys=keys)
        assert s.run().status == "finished"
        t = store.query("SELECT outcome, frames FROM trials ORDER BY trial_id LIMIT 1")[0]
        assert t["outcome"] == "skipped" and t["frames"] == 6
        step = [r for r in store.steps("P02") if r.kind == "trial"][0]
        assert (step.status, step.reason) == ("skipped", "headset slipped")


def test_terminal_participant_types_and_confirms(tmp_path: Path) -> None:
    proto = tmp_path / "t.toml"
    qdir = Path(__file__).resolve().parents[2] / "user_study" / "questionnaires"
    proto.write_text(f'[study]\nname = "t"\nseed = 1\nconditions = ["pedvr"]\nquestionnaire_dir = "{qdir}"\n'
                     '[[steps]]\nid = "consent"\nkind = "questionnaire"\nquestionnaire = "consent"\n'
                     '[[steps]]\nid = "demo"\nkind = "questionnaire"\nquestionnaire = "demographics"\n'
                     '[[steps]]\nid = "fb"\nkind = "questionnaire"\nquestionnaire = "feedback"\n')
    typed = io.StringIO("\n".join([
        "",  # the consent form's information page: Enter
        "1", "y",  # consent: yes, confirmed
        "12", "abc", "30", "n", "31", "y",  # age: out of range, not a number, 30 not confirmed, 31 confirmed
        "", "y",  # gender: optional, left empty
        "it was, \"fine\"", "y",
    ]) + "\n")
    screen = io.StringIO()
    who = TerminalParticipant(stdin=typed, stdout=screen)
    with StudyStore(tmp_path / "t.sqlite") as store:
        s, _ = _session(proto, store, "P01", participant=who)
        assert s.run().status == "finished"
        rows = {r["item"]: (r["raw_value"], r["text"]) for r in store.query("SELECT * FROM answers")}
    assert rows == {"consent": (None, "yes"), "age": (31.0, None), "gender": (None, None),
                    "comments": (None, 'it was, "fine"')}
    shown = screen.getvalue()
    assert "demographics.age = 12.0: expected a number in 16..110" in shown and "please type a number" in shown


def test_declined_consent_ends_the_session(tmp_path: Path) -> None:
    class Decliner(SimulatedParticipant):
        def ask(self, question):  # type: ignore[no-untyped-def]
            from pedvr.study.questionnaire import Response

            return Response(text="no") if question.item.kind == "consent" else super().ask(question)

    proto = shortened_protocol(tmp_path)
    with StudyStore(tmp_path / "c.sqlite") as store:
        s, _ = _session(proto, store, "P05", participant=Decliner(seed=1, number=5))
        r = s.run()
        assert r.status == "withdrawn"
        assert store.participant("P05")["status"] == "withdrawn"
        assert store.query("SELECT COUNT(*) AS n FROM trials")[0]["n"] == 0
        s, _ = _session(proto, store, "P05", resume=True)
        with pytest.raises(StudyStoreError, match="declined consent; there is nothing to resume"):
            s.run()


def test_cli_run_refuses_existing_participant(tmp_path: Path, mini_protocol: Path) -> None:
    db = tmp_path / "cli.sqlite"
    argv = ["run", str(mini_protocol), "--participant", "simulated", "--backend", "headless", "--db", str(db)]
    out = io.StringIO()
    assert run_study_command(build_parser().parse_args(argv), stdout=out, stdin=io.StringIO()) == 0
    assert "participant SIM01 finished the protocol" in out.getvalue()
    argv = ["run", str(mini_protocol), "--participant", "SIM01", "--simulated", "--backend", "headless",
            "--db", str(db)]
    with pytest.raises(ParticipantExistsError, match="participant SIM01 already exists"):
        run_study_command(build_parser().parse_args(argv), stdout=io.StringIO(), stdin=io.StringIO())
    from pedvr.study.cli import main

    assert main(["export", str(db), "--out", str(tmp_path / "e")]) == 0
    assert main(["export", str(tmp_path / "none.sqlite"), "--out", str(tmp_path / "e")]) == 2


def test_in_app_backend_that_cannot_start_is_refused_clearly(mini_protocol: Path, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    from pedvr.errors import BackendUnavailableError

    monkeypatch.setattr("pedvr.xr.select.openxr_missing", lambda: "no OpenXR runtime is active")
    db = tmp_path / "x.sqlite"
    argv = ["run", str(mini_protocol), "--participant", "P01", "--backend", "xr", "--db", str(db)]
    with pytest.raises(BackendUnavailableError, match=r"cannot start the OpenXR backend: .*use --backend headless"):
        run_study_command(build_parser().parse_args(argv), stdout=io.StringIO(), stdin=io.StringIO())
    assert not db.exists()  # refused before the database is touched


def test_not_a_study_database(tmp_path: Path) -> None:
    f = tmp_path / "other.sqlite"
    with sqlite3.connect(f) as c:
        c.execute("CREATE TABLE x (a)")
    with pytest.raises(StudyStoreError, match=r"other\.sqlite: a SQLite database, but not a pedvr study database"):
        StudyStore(f)
    g = tmp_path / "junk.sqlite"
    g.write_bytes(b"this is not sqlite at all, just some bytes" * 100)
    with pytest.raises(StudyStoreError, match=r"junk\.sqlite: not a SQLite database"):
        StudyStore(g)
    # the same answers when opened read-only, as analysis and export do
    with pytest.raises(StudyStoreError, match=r"junk\.sqlite: not a SQLite database"):
        StudyStore(g, read_only=True)
    with pytest.raises(StudyStoreError, match=r"other\.sqlite: a SQLite database, but not a pedvr study database"):
        StudyStore(f, read_only=True)
    with pytest.raises(StudyStoreError, match=r"missing\.sqlite: no such study database"):
        StudyStore(tmp_path / "missing.sqlite", read_only=True)


def test_sessions_record_the_version_and_commit_of_the_code() -> None:
    import subprocess

    import pedvr
    from pedvr.study.session import software_version

    v = software_version()
    assert v.startswith(pedvr.__version__)
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                          cwd=Path(pedvr.__file__).parent).stdout.strip()
    if head:  # a git checkout: the commit is named, so a methods section can cite the exact code
        assert f"+g{head[:10]}" in v
