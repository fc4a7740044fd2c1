"""The store and export, hardened: response times, interrupted trials flagged, older schemas, read-only
databases, moved study folders, and one-line errors for bad output paths."""

from __future__ import annotations

import hashlib
import json
import shutil
import sqlite3
from pathlib import Path

import pandas as pd
import pytest

from pedvr.study.cli import main
from pedvr.study.console import ScriptedKeys
from pedvr.study.errors import StudyStoreError
from pedvr.study.export import export_study
from pedvr.study.presenter import SimulatedParticipant
from pedvr.study.protocol import scene_path
from pedvr.study.store import SCHEMA_VERSION, StudyStore

from .conftest import DATA, ROOT, InterruptingParticipant, run_session

MINI = DATA / "mini.toml"


class SlowParticipant(SimulatedParticipant):
    """Answers the k-th question after 0.5 + 0.25 k seconds on an injected clock (``tick``)."""

    def __init__(self, clock: list[float], **kw: object) -> None:
        super().__init__(**kw)  # type: ignore[arg-type]
        self.clock, self.asked = clock, 0

    def ask(self, question):  # type: ignore[no-untyped-def]
        self.asked += 1
        self.clock[0] += 0.5 + 0.25 * self.asked
        return super().ask(question)


def test_response_times_are_stored_and_exported(tmp_path: Path) -> None:
    now = [100.0]
    who = SlowParticipant(now, seed=5, number=1)
    with StudyStore(tmp_path / "rt.sqlite") as store:
        result, _ = run_session(MINI, store, "P01", participant=who, clock=lambda: now[0])
        assert result.status == "finished"
        rows = store.query("SELECT answer_id, response_time_s, answered_utc FROM answers ORDER BY answer_id")
    assert len(rows) == who.asked
    assert [r["response_time_s"] for r in rows] == pytest.approx([0.5 + 0.25 * k for k in range(1, len(rows) + 1)])
    assert all(r["answered_utc"].endswith("Z") for r in rows)  # the UTC timestamp stays
    export_study(tmp_path / "rt.sqlite", out=tmp_path / "x")
    answers = pd.read_csv(tmp_path / "x" / "answers.tsv", sep="\t")
    assert answers["response_time_s"].tolist() == pytest.approx([r["response_time_s"] for r in rows])


@pytest.fixture(scope="module")
def interrupted_db(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """P01 through the mini protocol: Ctrl-C in the 3rd trial at its 10th frame, then --resume to the end."""
    db = tmp_path_factory.mktemp("interrupted") / "i.sqlite"
    with StudyStore(db) as store:
        inner = SimulatedParticipant(seed=5, number=1)
        frames = {"n": 0}

        class CutInThirdTrial(InterruptingParticipant):
            def trial_input(self, **kw):  # type: ignore[no-untyped-def]
                frames["n"] += 1
                self.frames = 0
                self.armed = frames["n"] == 3
                return self.inner.trial_input(**kw)

            def present(self, sim):  # type: ignore[no-untyped-def]
                if self.armed:
                    return super().present(sim)
                return self.inner.present(sim)

        who = CutInThirdTrial(inner, at=10, exc=KeyboardInterrupt())
        with pytest.raises(KeyboardInterrupt):
            run_session(MINI, store, "P01", participant=who)
        result, _ = run_session(MINI, store, "P01", resume=True)
        assert result.status == "finished"
    return db


def test_an_interrupted_trial_is_marked_at_once_and_flagged_in_the_export(interrupted_db: Path, tmp_path: Path) -> None:
    with StudyStore(interrupted_db, read_only=True) as store:
        trials = store.query("SELECT trial_id, step_key, outcome, frames FROM trials ORDER BY trial_id")
        sessions = store.query("SELECT status FROM sessions ORDER BY session_id")
        events = store.query("SELECT kind, detail FROM events ORDER BY event_id")
    cut = [t for t in trials if t["outcome"] == "interrupted"]
    assert len(cut) == 1 and cut[0]["frames"] == 10  # marked when it happened, with the frames it had
    rerun = [t for t in trials if t["step_key"] == cut[0]["step_key"] and t["outcome"] != "interrupted"]
    assert len(rerun) == 1 and rerun[0]["outcome"] == "time_limit"
    assert [s["status"] for s in sessions] == ["aborted", "finished"]
    assert ("abort", "interrupted (Ctrl-C)") in [(e["kind"], e["detail"]) for e in events]

    export_study(interrupted_db, out=tmp_path / "x")
    samples = pd.read_csv(tmp_path / "x" / "samples.tsv", sep="\t")
    flagged = samples.groupby("trial_id")["interrupted"].agg(["min", "max", "size"])
    assert flagged.loc[cut[0]["trial_id"]].tolist() == [1, 1, 10]
    assert (flagged.drop(index=cut[0]["trial_id"])["max"] == 0).all()
    # so the samples alone count every step once
    done = samples[samples["interrupted"] == 0]
    assert done["trial_id"].nunique() == len(trials) - 1
    traj = pd.read_csv(tmp_path / "x" / "trajectories" / f"trial-{cut[0]['trial_id']:05d}.tsv", sep="\t")
    assert (traj["interrupted"] == 1).all() and traj["frame"].max() == 9
    measures = pd.read_csv(tmp_path / "x" / "trial_measures.tsv", sep="\t")
    assert measures.set_index("trial_id").loc[cut[0]["trial_id"], "complete"] == 0


def test_export_refuses_to_overwrite_unless_forced(interrupted_db: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "x"
    assert main(["export", str(interrupted_db), "--out", str(out)]) == 0
    before = (out / "answers.tsv").read_bytes()
    (out / "answers.tsv").write_text("edited by hand\n")
    capsys.readouterr()
    assert main(["export", str(interrupted_db), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"pedvr: error: {out}/participants.tsv: already exists (and ")
    assert err[0].endswith("more); use --force to overwrite")
    assert (out / "answers.tsv").read_text() == "edited by hand\n"  # nothing was written
    assert main(["export", str(interrupted_db), "--out", str(out), "--force"]) == 0
    assert (out / "answers.tsv").read_bytes() == before


def test_bad_output_paths_are_one_line(interrupted_db: Path, tmp_path: Path, capsys: pytest.CaptureFixture,
                                       read_only) -> None:  # type: ignore[no-untyped-def]
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    locked = tmp_path / "locked"
    locked.mkdir()
    read_only(locked)
    cases = [
        (["export", str(interrupted_db), "--out", str(a_file)],
         f"pedvr: error: {a_file}: not a folder; the export needs a folder"),
        (["export", str(interrupted_db), "--out", str(a_file / "sub")],
         f"pedvr: error: {a_file / 'sub'}: {a_file} is a file, not a folder"),
        (["export", str(interrupted_db), "--out", str(locked / "new")],
         f"pedvr: error: {locked / 'new'}: cannot create the export folder: "),
        (["export", str(interrupted_db), "--out", str(locked)],
         f"pedvr: error: {locked}: cannot write into the export folder: "),
        (["analyze", str(interrupted_db), "--report", str(a_file)],
         f"pedvr: error: {a_file}: not a folder; the report needs a folder"),
        (["analyze", str(interrupted_db), "--report", str(locked / "r")],
         f"pedvr: error: {locked / 'r'}: cannot create the report folder: "),
    ]
    for argv, want in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(want), (argv, err)


def test_a_read_only_database_is_analysed_and_exported(interrupted_db: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture, read_only) -> None:  # type: ignore[no-untyped-def]
    folder = tmp_path / "ro"
    folder.mkdir()
    db = folder / "study.sqlite"
    shutil.copy(interrupted_db, db)
    digest = hashlib.sha256(db.read_bytes()).hexdigest()
    read_only(db, folder)  # neither the file nor its folder can be written (a read-only medium)
    assert main(["analyze", str(db), "--json"]) == 0
    assert '"n_participants": 1' in capsys.readouterr().out
    assert main(["export", str(db), "--out", str(tmp_path / "x")]) == 0
    assert len(list((tmp_path / "x" / "trajectories").glob("*.tsv"))) == 6
    assert hashlib.sha256(db.read_bytes()).hexdigest() == digest
    with pytest.raises(StudyStoreError, match=r"study\.sqlite: cannot open the study database for writing"):
        StudyStore(db)


def test_an_older_schema_is_migrated_or_read_through_views(interrupted_db: Path, tmp_path: Path) -> None:
    db = tmp_path / "v2.sqlite"
    shutil.copy(interrupted_db, db)
    with sqlite3.connect(db) as c:  # what a version-2 database looked like
        c.execute("ALTER TABLE gaze_events DROP COLUMN source")
        c.execute("DROP TABLE demonstrations")
        c.execute("ALTER TABLE answers DROP COLUMN response_time_s")
        c.execute("ALTER TABLE samples DROP COLUMN spheres")
        c.execute("UPDATE meta SET value = '2' WHERE key = 'schema_version'")
    digest = hashlib.sha256(db.read_bytes()).hexdigest()
    with StudyStore(db, read_only=True) as store:
        assert store.query("SELECT COUNT(*) AS n FROM answers WHERE response_time_s IS NULL")[0]["n"] > 0
        assert store.query("SELECT MAX(spheres) AS s FROM samples")[0]["s"] is None
        assert store.query("SELECT COUNT(*) AS n FROM demonstrations")[0]["n"] == 0  # an empty stand-in
    export_study(db, out=tmp_path / "x")
    assert "response_time_s" in pd.read_csv(tmp_path / "x" / "answers.tsv", sep="\t").columns
    assert hashlib.sha256(db.read_bytes()).hexdigest() == digest  # read-only: not migrated, not touched
    with StudyStore(db) as store:  # opened for writing: migrated
        assert store.query("SELECT value FROM meta WHERE key = 'schema_version'")[0]["value"] == SCHEMA_VERSION
        cols = {r["name"] for r in store.query("PRAGMA table_info(samples)")}
        assert "spheres" in cols
        assert "source" in {r["name"] for r in store.query("PRAGMA table_info(gaze_events)")}
        assert store.query("SELECT COUNT(*) AS n FROM demonstrations")[0]["n"] == 0


def test_resume_of_a_missing_database_says_so_and_creates_nothing(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    db = tmp_path / "nope" / "missing.sqlite"
    code = main(["run", str(MINI), "--participant", "P01", "--simulated", "--backend", "headless", "--resume",
                 "--db", str(db)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"pedvr: error: --resume: {db}: no such study database (nothing was created); give the database "
                   "the participant started in with --db, or run from the folder that holds it"]
    assert not db.exists() and not db.parent.exists()


def _study_folder(folder: Path) -> Path:
    """A study folder as an experimenter keeps one: protocol, its questionnaires and a scene of its own."""
    (folder / "scenes").mkdir(parents=True)
    shutil.copytree(ROOT / "user_study" / "questionnaires", folder / "questionnaires")
    shutil.copy(ROOT / "user_study" / "scenes" / "training.toml", folder / "scenes" / "training.toml")
    (folder / "walk.toml").write_text(
        '[study]\nname = "walk"\nseed = 4\nconditions = ["pedvr"]\n'
        '[[steps]]\nid = "ssq_pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n'
        '[[steps]]\nid = "training"\nkind = "trial"\nscene = "scenes/training.toml"\ncondition = "pedvr"\n'
        'time_limit_s = 0.3\n'
        '[[steps]]\nid = "corridor"\nkind = "trial"\nscene = "headon_corridor"\ncondition = "pedvr"\n'
        'time_limit_s = 0.3\n')
    return folder / "walk.toml"


def test_resume_after_moving_the_study_folder(tmp_path: Path) -> None:
    proto = _study_folder(tmp_path / "lab-pc" / "walk")
    with StudyStore(proto.parent / "walk.sqlite") as store:
        result, _ = run_session(proto, store, "P01", keys=ScriptedKeys([None] * 6 + ["a", "yes"]))
        assert result.status == "aborted"
        spec = store.query("SELECT spec FROM steps WHERE step_key = 'training'")[0]["spec"]
    assert '"scene": "scenes/training.toml"' in spec and str(tmp_path) not in spec  # relative, not absolute
    moved = tmp_path / "usb-stick" / "walk"
    shutil.move(proto.parent, moved)
    with StudyStore(moved / "walk.sqlite") as store:
        result, _ = run_session(moved / "walk.toml", store, "P01", resume=True)
        assert result.status == "finished"
        assert store.query("SELECT scene_source FROM trials WHERE step_key = 'training'")[0]["scene_source"] == \
            str((moved / "scenes" / "training.toml").resolve())


def test_resume_with_a_changed_scene_or_protocol_says_what_differs(tmp_path: Path) -> None:
    proto = _study_folder(tmp_path / "walk")
    db = proto.parent / "walk.sqlite"
    with StudyStore(db) as store:
        run_session(proto, store, "P01", keys=ScriptedKeys([None] * 6 + ["a", "yes"]))
    scene = proto.parent / "scenes" / "training.toml"
    scene.write_text(scene.read_text().replace("sphere_radius = 0.5", "sphere_radius = 0.6"))
    with StudyStore(db) as store, pytest.raises(StudyStoreError) as exc:
        run_session(proto, store, "P01", resume=True)
    lines = str(exc.value).splitlines()
    assert lines[0].startswith("participant P01: the stored plan (number 1) differs from what ")
    assert len(lines) == 2 and lines[1].startswith("step 2 (training): scene scenes/training.toml changed since the "
                                                   "participant started (content hash ")
    scene.write_text(scene.read_text().replace("sphere_radius = 0.6", "sphere_radius = 0.5"))
    proto.write_text(proto.read_text().replace('time_limit_s = 0.3\n[[steps]]\nid = "corridor"',
                                               'time_limit_s = 0.4\n[[steps]]\nid = "corridor"'))
    with StudyStore(db) as store, pytest.raises(StudyStoreError) as exc:
        run_session(proto, store, "P01", resume=True)
    lines = str(exc.value).splitlines()
    assert lines[0].startswith("participant P01 started with protocol ") and "resume with the original protocol" in lines[0]
    assert lines[1:] == ["step 2 (training): trial.time_limit_s was 0.3, the protocol now gives 0.4"]


def test_a_participant_started_before_relative_scene_references_still_resumes(tmp_path: Path) -> None:
    proto = _study_folder(tmp_path / "walk")
    db = proto.parent / "walk.sqlite"
    with StudyStore(db) as store:
        run_session(proto, store, "P01", keys=ScriptedKeys([None] * 6 + ["a", "yes"]))
        # what schema 2 stored: the scene as an absolute path (a shipped one too), no content hash
        for r in store.query("SELECT step_index, spec FROM steps WHERE kind = 'trial'"):
            spec = json.loads(r["spec"])
            spec["trial"]["scene"] = str(scene_path(spec["trial"]["scene"], proto.parent))
            del spec["trial"]["scene_hash"]
            store.db.execute("UPDATE steps SET spec = ? WHERE participant = 'P01' AND step_index = ?",
                             (json.dumps(spec, sort_keys=True), r["step_index"]))
        result, _ = run_session(proto, store, "P01", resume=True)
        assert result.status == "finished"
