"""The standard instruments and objective measures through a simulated study, the analysis of partial
databases (only the SSQ, one questionnaire, nothing), and the HTML report in a real headless browser."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from pedvr.study.analysis import analyze
from pedvr.study.console import ScriptedKeys
from pedvr.study.errors import StudyStoreError
from pedvr.study.measures import trial_measures
from pedvr.study.presenter import SimulatedParticipant
from pedvr.study.questionnaire import Response
from pedvr.study.report import write_report
from pedvr.study.store import StudyStore

from .conftest import QDIR_SHIPPED, STANDARD, run_session, shortened_protocol

CHROMIUM = next((p for p in (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) if p), None)


class Decliner(SimulatedParticipant):
    def ask(self, question):  # type: ignore[no-untyped-def]
        return Response(text="no") if question.item.kind == "consent" else super().ask(question)


@pytest.fixture(scope="module")
def standard_study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Four simulated participants through the standard-measures protocol (short trials), one who declines
    consent and one whose session the experimenter aborts in the first SSQ."""
    folder = tmp_path_factory.mktemp("standard")
    proto = shortened_protocol(folder, source=STANDARD)
    db = folder / "standard.sqlite"
    with StudyStore(db) as store:
        for k in range(1, 5):
            assert run_session(proto, store, f"P{k:02d}")[0].status == "finished"
        assert run_session(proto, store, "P05", participant=Decliner(seed=1, number=5))[0].status == "withdrawn"
        keys = ScriptedKeys([None] * 8 + ["a", "yes"])
        assert run_session(proto, store, "P06", keys=keys)[0].status == "aborted"
    return db


@pytest.fixture(scope="module")
def standard_result(standard_study: Path) -> dict:
    return analyze(db=standard_study)


def _hand_rm_anova(y: np.ndarray) -> float:
    n, k = y.shape
    gm = y.mean()
    ss_cond = n * ((y.mean(axis=0) - gm) ** 2).sum()
    ss_subj = k * ((y.mean(axis=1) - gm) ** 2).sum()
    ss_err = ((y - gm) ** 2).sum() - ss_cond - ss_subj
    return (ss_cond / (k - 1)) / (ss_err / ((n - 1) * (k - 1)))


def test_questionnaire_scores_by_condition(standard_study: Path, standard_result: dict) -> None:
    res = standard_result
    qs = res["questionnaires"]
    assert qs["scoring"] == {"ipq": "ipq", "copresence": "copresence", "nasa_tlx_raw": "nasa_tlx",
                             "slater_usoh_steed": "slater_usoh_steed", "sus": "sus"}
    block = qs["by_block"]["ipq"]["antipodal_circle"]
    assert block["levels"] == ["decoupled", "pedvr", "pedvr+g"]
    # spatial presence by hand from the raw answers: mean of SP1..SP5 with SP2 reversed (6 - answer)
    with StudyStore(standard_study, read_only=True) as store:
        rows = store.query("SELECT participant, condition, item, raw_value FROM answers WHERE questionnaire = 'ipq' "
                           "AND block = 'antipodal_circle' AND item LIKE 'sp%'")
    by: dict[tuple[str, str], list[float]] = {}
    for r in rows:
        v = 6 - r["raw_value"] if r["item"] == "sp2" else r["raw_value"]
        by.setdefault((r["participant"], r["condition"]), []).append(v)
    people = [f"P{k:02d}" for k in range(1, 5)]
    y = np.array([[np.mean(by[(p, c)]) for c in block["levels"]] for p in people])
    sp = block["scores"]["spatial_presence"]
    assert [sp["levels"][c]["mean"] for c in block["levels"]] == pytest.approx(y.mean(axis=0).tolist())
    assert sp["n"] == 4 and sp["rm_anova"]["F"] == pytest.approx(_hand_rm_anova(y))
    assert sp["friedman"]["Q"] == pytest.approx(stats.friedmanchisquare(*y.T).statistic)
    # given once, without a condition: described, not compared
    sus = qs["once"]["sus"]["sus_score"]
    scores = [a["scores"]["sus_score"] for a in qs["administrations"] if a["questionnaire"] == "sus"]
    assert sus["n"] == 4 and sus["mean"] == pytest.approx(np.mean(scores))


def test_objective_measures_by_condition_and_responsibility(standard_study: Path, standard_result: dict) -> None:
    res = standard_result
    m = res["measures"]
    with StudyStore(standard_study, read_only=True) as store:
        tm = trial_measures(store)
    block = m["by_block"]["bidirectional_flow"]
    assert block["design"] == "block" and block["levels"] == ["decoupled", "pedvr", "pedvr+g"]
    done = tm[(tm["block"] == "bidirectional_flow") & (tm["complete"] == 1)]
    for c in block["levels"]:
        want = done.loc[done["condition"] == c, "min_distance_m"].mean()
        assert block["measures"]["min_distance_m"]["levels"][c]["mean"] == pytest.approx(want)
    sweep = m["by_block"]["corridor"]
    assert sweep["design"] == "sweep" and sweep["levels"] == ["rho=0", "rho=0.25", "rho=0.5", "rho=1"]
    assert set(block["measures"]) >= {"min_distance_m", "contacts", "path_length_m", "head_yaw_sd_deg",
                                      "gaze_events_received"}
    # gaze events only under PedVR+G
    g = block["measures"]["gaze_events_received"]["levels"]
    assert g["decoupled"]["mean"] == g["pedvr"]["mean"] == 0


def test_sample_description(standard_result: dict) -> None:
    s = standard_result["sample"]
    assert s["participants"] == 6 and s["by_status"] == {"finished": 4, "withdrawn": 1, "in_progress": 1}
    assert s["withdrawn"] == ["P05"] and s["not_finished"] == ["P06"]
    assert [(a["participant"], a["step"], a["detail"]) for a in s["aborts"]] == [("P06", "ssq_pre", None)]
    # everyone who answered the demographics: the four who finished and P06 (aborted after them)
    assert s["demographics"]["age"]["n"] == 5 and sum(s["demographics"]["gender"]["counts"].values()) == 5


def test_levels_carry_95_ci_and_the_figures_draw_them(standard_result: dict, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 25.6: the per-condition figures show the mean and its 95 % CI (not ± SD), and say so."""
    sp = standard_result["questionnaires"]["by_block"]["ipq"]["antipodal_circle"]["scores"]["spatial_presence"]
    for lv, d in sp["levels"].items():
        half = stats.t.ppf(0.975, d["n"] - 1) * d["sd"] / np.sqrt(d["n"])
        assert d["ci95"] == pytest.approx([d["mean"] - half, d["mean"] + half]), lv
        assert half != pytest.approx(d["sd"])  # with 4 participants the two differ: the test can tell
    drawn: list[tuple[float, float, float]] = []
    import matplotlib.axes

    real = matplotlib.axes.Axes.errorbar

    def spy(self, x, y, yerr=None, **kw):  # type: ignore[no-untyped-def]
        drawn.append((y[0], y[0] - yerr[0][0], y[0] + yerr[1][0]))
        return real(self, x, y, yerr=yerr, **kw)

    monkeypatch.setattr(matplotlib.axes.Axes, "errorbar", spy)
    write_report(standard_result, out=tmp_path / "rep")
    want = [(d["mean"], *d["ci95"]) for d in sp["levels"].values()]
    assert all(any(np.allclose(w, g) for g in drawn) for w in want)  # the spatial presence panel's three bars
    svg = (tmp_path / "rep" / "scores_ipq_antipodal_circle.svg").read_text()
    assert "mean and 95 % confidence interval" in svg and "± SD" not in svg
    md = (tmp_path / "rep" / "report.md").read_text()
    assert md.count("Figures show each condition's mean and its 95 % confidence interval (t distribution with "
                    "n − 1 degrees of freedom over the participants with that condition; not the SD).") == 2


def test_post_hoc_tests_of_scores_and_measures_give_effect_sizes(standard_result: dict, tmp_path: Path) -> None:
    md = write_report(standard_result, out=tmp_path / "rep").with_suffix(".md").read_text()
    sp = standard_result["questionnaires"]["by_block"]["ipq"]["antipodal_circle"]["scores"]["spatial_presence"]
    for ph in sp["posthoc_bonferroni"]:
        assert ph["hedges_g"] is not None
        assert f"t({ph['dof']:g}) = {ph['t']:.2f}, " in md and f"Hedges' g = {ph['hedges_g']:.2f}" in md
    scores = md.split("## Questionnaire scores", 1)[1].split("## Objective measures", 1)[0]
    assert scores.count("Post hoc (paired, Bonferroni):") == scores.count("Hedges' g = ") // 3 > 0


def test_a_dry_run_reports_no_response_times(standard_result: dict, tmp_path: Path) -> None:
    """Simulated participants answer at once: their 0.00 s are left out and the report says why."""
    assert standard_result["sample"]["simulated"] == 6 and standard_result["response_times"] == {}
    md = write_report(standard_result, out=tmp_path / "rep").with_suffix(".md").read_text()
    rt = md.split("## Response times", 1)[1]
    assert rt.strip().startswith("None to report: the answers come from 6 simulated participants (a dry run)")
    assert "0.00" not in rt and "| questionnaire |" not in rt
    assert "A dry run: all 6 participants are simulated" in md


def test_response_times_of_people_leave_the_simulated_out(tmp_path: Path) -> None:
    from pedvr.study.console import ExperimenterConsole, NoKeys
    from pedvr.study.protocol import load_protocol
    from pedvr.study.session import Session

    proto = tmp_path / "rt.toml"
    proto.write_text(f'[study]\nname = "rt"\nseed = 3\nconditions = ["pedvr"]\nquestionnaire_dir = "{QDIR_SHIPPED}"\n'
                     '[[steps]]\nid = "pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n')
    db = tmp_path / "rt.sqlite"
    now = [0.0]

    class Person(SimulatedParticipant):  # a person who takes 1.5 s per answer (on the injected clock)
        kind = "terminal"

        def ask(self, question):  # type: ignore[no-untyped-def]
            now[0] += 1.5
            return super().ask(question)

    import io

    with StudyStore(db) as store:
        run_session(proto, store, "P01")  # simulated
        console = ExperimenterConsole(out=io.StringIO(), keys=NoKeys(), live=False, clock=lambda: now[0])
        Session(protocol=load_protocol(proto), store=store, participant_id="P02", participant=Person(seed=3, number=2),
                console=console, backend="headless").run()
    res = analyze(db=db)
    assert res["response_times"]["ssq"]["n"] == 16 and res["response_times"]["ssq"]["median_s"] == pytest.approx(1.5)
    md = write_report(res, out=tmp_path / "rep").with_suffix(".md").read_text()
    rt = md.split("## Response times", 1)[1]
    assert "The 1 simulated participant' answers are left out" not in rt  # grammar: one participant
    assert "The 1 simulated participant's answers are left out (they take no time)." in rt
    assert "| ssq | 16 | 1.50 | 1.50–1.50 |" in rt


def test_a_database_with_only_the_ssq_is_analysed(tmp_path: Path) -> None:
    proto = tmp_path / "ssq_only.toml"
    proto.write_text(f'[study]\nname = "s"\nseed = 3\nconditions = ["pedvr"]\nquestionnaire_dir = "{QDIR_SHIPPED}"\n'
                     '[[steps]]\nid = "pre"\nkind = "questionnaire"\nquestionnaire = "ssq"\n'
                     '[[steps]]\nid = "post"\nkind = "questionnaire"\nquestionnaire = "ssq"\n')
    db = tmp_path / "s.sqlite"
    with StudyStore(db) as store:
        for k in range(1, 9):
            run_session(proto, store, f"P{k:02d}")
    res = analyze(db=db)
    assert res["scenarios"] == {} and res["n_responses"] == 0
    per = res["ssq"]["participants"]
    before = np.array([p["before"]["total"] for p in per])
    after = np.array([p["after"]["total"] for p in per])
    t = res["ssq"]["tests"]["total"]
    assert t["n"] == 8 and t["mean_change"] == pytest.approx((after - before).mean())
    st = stats.ttest_rel(after, before)
    assert t["t"]["t"] == pytest.approx(st.statistic) and t["t"]["p"] == pytest.approx(st.pvalue)
    d = after - before
    assert t["t"]["cohen_dz"] == pytest.approx(d.mean() / d.std(ddof=1))
    w = stats.wilcoxon(after, before)
    assert t["wilcoxon"]["W"] == pytest.approx(w.statistic) and t["wilcoxon"]["p"] == pytest.approx(w.pvalue)
    nz = d[d != 0]
    r = stats.rankdata(np.abs(nz))
    assert t["wilcoxon"]["rank_biserial"] == pytest.approx((r[nz > 0].sum() - r[nz < 0].sum()) / r.sum())
    for k in ("nausea", "oculomotor", "disorientation"):  # subscale means before and after
        assert res["ssq"]["summary"]["after"][k]["mean"] == pytest.approx(np.mean([p["after"][k] for p in per]))
    html = write_report(res, out=tmp_path / "rep").read_text()
    assert "Change from before to after" in html and "Wilcoxon signed-rank" in html


def test_a_database_with_one_questionnaire_or_nothing(tmp_path: Path) -> None:
    proto = tmp_path / "ipq_only.toml"
    proto.write_text(f'[study]\nname = "i"\nseed = 3\nconditions = ["pedvr"]\nquestionnaire_dir = "{QDIR_SHIPPED}"\n'
                     '[[steps]]\nid = "ipq"\nkind = "questionnaire"\nquestionnaire = "ipq"\n')
    db = tmp_path / "i.sqlite"
    with StudyStore(db) as store:
        run_session(proto, store, "P01")
        run_session(proto, store, "P02")
    res = analyze(db=db)
    assert res["questionnaires"]["once"]["ipq"]["spatial_presence"]["n"] == 2
    empty = tmp_path / "empty.sqlite"
    StudyStore(empty).close()
    with pytest.raises(StudyStoreError, match=r"empty\.sqlite: nothing to analyse yet: no answers and no trial that "
                                              r"ran to its end"):
        analyze(db=empty)


def _browser(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    assert CHROMIUM is not None
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
           "--disable-component-update", "--disable-sync", f"--user-data-dir={cwd / 'profile'}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=cwd,
                          env={**os.environ, "HOME": str(cwd)})


@pytest.mark.skipif(CHROMIUM is None, reason="no headless browser here (apt-get install chromium): "
                                             "the HTML report's rendering is checked in one")
def test_the_html_report_renders_in_a_headless_browser(standard_result: dict, tmp_path: Path) -> None:
    page = write_report(standard_result, out=tmp_path / "rep")
    assert (tmp_path / "rep" / "report.md").is_file()
    figures = sorted(p.name for p in (tmp_path / "rep").glob("*.svg"))
    assert "corridor_trajectories.svg" in figures and "measures_antipodal_circle.svg" in figures
    assert "scores_ipq_antipodal_circle.svg" in figures
    # The page as shipped, plus a script that reports what the browser laid out for each inline figure.
    probe = page.read_text().replace("</body>", """<script>
const rows = [...document.querySelectorAll('figure')].map(f => {
  const s = f.querySelector('svg'); const b = s ? s.getBoundingClientRect() : {width: 0, height: 0};
  return [f.id, s ? s.namespaceURI : 'none', Math.round(b.width), Math.round(b.height),
          s ? s.querySelectorAll('path').length : 0].join(' ');
});
const pre = document.createElement('pre'); pre.id = 'probe'; pre.textContent = rows.join('\\n');
document.body.appendChild(pre);
</script></body>""")
    (tmp_path / "rep" / "probe.html").write_text(probe)
    dom = _browser("--dump-dom", (tmp_path / "rep" / "probe.html").as_uri(), cwd=tmp_path)
    assert dom.returncode == 0, dom.stderr[-2000:]
    text = dom.stdout.split('<pre id="probe">', 1)[1].split("</pre>", 1)[0]
    laid_out = {line.split()[0]: line.split()[1:] for line in text.strip().splitlines()}
    assert sorted(laid_out) == sorted(f"fig-{Path(f).stem}" for f in figures)
    for fig, (ns, w, h, paths) in laid_out.items():
        assert ns == "http://www.w3.org/2000/svg" and int(w) > 200 and int(h) > 150 and int(paths) > 10, fig
    assert "<h2>Sample</h2>" in dom.stdout and "<h2>Objective measures</h2>" in dom.stdout
    assert "<h2>Head-on corridor by responsibility</h2>" in dom.stdout
    # and a figure is really drawn: the corridor plot, rendered to pixels, holds the participant's blue
    # and the agent's red paths
    shot = tmp_path / "corridor.png"
    r = _browser(f"--screenshot={shot}", "--window-size=900,1000", (tmp_path / "rep" / "corridor_trajectories.svg").as_uri(),
                 cwd=tmp_path)
    assert r.returncode == 0 and shot.is_file(), r.stderr[-2000:]
    from PIL import Image

    px = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3).astype(int)
    for rgb in ((0x3B, 0x6F, 0xB6), (0xC8, 0x55, 0x3D)):
        assert (np.abs(px - rgb).sum(axis=1) < 40).sum() > 50, rgb  # a blank or failed render has none
