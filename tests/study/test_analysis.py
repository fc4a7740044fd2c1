"""The §6.5 analysis against hand computations on small data, and bad answer files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from pedvr.study.analysis import (
    analyze,
    apa_p,
    apa_rm_anova,
    read_responses_csv,
    who_gave_way,
)
from pedvr.study.cli import build_parser, run_study_command
from pedvr.study.errors import AnswerError

COMPS = ["pedvr+g/decoupled", "pedvr/decoupled", "pedvr+g/pedvr"]
QUESTIONS = ["q1", "q2", "q3"]
# responses[participant][comparison] = answers to q1..q3 (fixed orientation, 1 = left much better)
DATA = {
    "P1": [[1, 2, 1], [3, 4, 3], [2, 2, 1]],
    "P2": [[2, 2, 3], [4, 4, 5], [1, 1, 2]],
    "P3": [[1, 1, 1], [3, 3, 4], [3, 2, 2]],
    "P4": [[4, 3, 3], [4, 5, 4], [2, 3, 2]],
    "P5": [[2, 1, 2], [5, 4, 4], [1, 2, 1]],
    "P6": [[3, 3, 2], [3, 4, 3], [1, 1, 1]],
}


def _csv(tmp_path: Path) -> Path:
    rows = ["participant,scenario,comparison,question,response"]
    for p, per in DATA.items():
        for c, answers in zip(COMPS, per, strict=True):
            for q, r in zip(QUESTIONS, answers, strict=True):
                rows.append(f"{p},antipodal_circle,{c},{q},{r}")
    f = tmp_path / "responses.csv"
    f.write_text("\n".join(rows) + "\n")
    return f


def _cube() -> np.ndarray:
    return np.asarray([DATA[p] for p in DATA], dtype=float)  # (participants, comparisons, questions)


def test_table3_quantities_by_hand(tmp_path: Path) -> None:
    res = analyze(responses=_csv(tmp_path))
    s = res["scenarios"]["antipodal_circle"]
    cube = _cube()
    for k, c in enumerate(COMPS):
        got = s["comparisons"][c]
        r = cube[:, k, :].ravel()
        idx = cube[:, k, :].mean(axis=1)
        assert got["n"] == 6 and got["n_responses"] == 18
        assert got["frequencies"] == {str(v): int((r == v).sum()) for v in range(1, 8)}
        assert got["mean"] == pytest.approx(idx.mean())
        assert got["sd"] == pytest.approx(idx.std(ddof=1))
        assert got["pct_less_than_4"] == pytest.approx(100 * (r < 4).mean())
        assert got["pct_equal_1"] == pytest.approx(100 * (r == 1).mean())
        assert got["pct_equal_4"] == pytest.approx(100 * (r == 4).mean())
        # Cronbach's alpha by hand: k/(k-1) (1 - sum item variances / variance of the sum)
        items = cube[:, k, :]
        kk = items.shape[1]
        alpha = kk / (kk - 1) * (1 - items.var(axis=0, ddof=1).sum() / items.sum(axis=1).var(ddof=1))
        assert got["cronbach_alpha"] == pytest.approx(alpha)
        t = stats.ttest_1samp(idx, 4.0)
        assert got["one_sample_t_vs_4"]["t"] == pytest.approx(t.statistic)
        assert got["one_sample_t_vs_4"]["p"] == pytest.approx(t.pvalue)
        assert got["one_sample_t_vs_4"]["dof"] == 5
        # the 95 % CI of the mean index, at full precision: mean ± t(.975, 5) SD / √6
        half = stats.t.ppf(0.975, 5) * idx.std(ddof=1) / np.sqrt(6)
        assert got["one_sample_t_vs_4"]["ci95"] == pytest.approx([idx.mean() - half, idx.mean() + half], abs=1e-12)


def test_rm_anova_mauchly_gg_by_hand(tmp_path: Path) -> None:
    s = analyze(responses=_csv(tmp_path))["scenarios"]["antipodal_circle"]
    y = _cube().mean(axis=2)  # participant indices, (n, k)
    n, k = y.shape
    gm = y.mean()
    ss_cond = n * ((y.mean(axis=0) - gm) ** 2).sum()
    ss_subj = k * ((y.mean(axis=1) - gm) ** 2).sum()
    ss_err = ((y - gm) ** 2).sum() - ss_cond - ss_subj
    df1, df2 = k - 1, (n - 1) * (k - 1)
    f = (ss_cond / df1) / (ss_err / df2)
    # Greenhouse-Geisser epsilon from the double-centred covariance matrix
    cov = np.cov(y, rowvar=False)
    c = np.eye(k) - 1.0 / k
    dc = c @ cov @ c
    eps = np.trace(dc) ** 2 / ((k - 1) * (dc**2).sum())
    # Mauchly's W on orthonormal contrasts
    m = np.linalg.qr(np.vstack([np.ones(k), np.eye(k)[:-1]]).T)[0][:, 1:]
    sig = m.T @ cov @ m
    w = np.linalg.det(sig) / (np.trace(sig) / (k - 1)) ** (k - 1)
    a = s["rm_anova"]
    assert a["F"] == pytest.approx(f)
    assert (a["df1"], a["df2"]) == (df1, df2)
    assert a["p"] == pytest.approx(stats.f.sf(f, df1, df2))
    assert a["gg_epsilon"] == pytest.approx(eps)
    assert a["df1_gg"] == pytest.approx(eps * df1) and a["df2_gg"] == pytest.approx(eps * df2)
    assert a["p_gg"] == pytest.approx(stats.f.sf(f, eps * df1, eps * df2))
    assert a["mauchly_W"] == pytest.approx(w)
    assert a["partial_eta_squared"] == pytest.approx(ss_cond / (ss_cond + ss_err))
    # Bonferroni post hoc = paired t-test p times 3 (capped at 1)
    for ph in s["posthoc_bonferroni"]:
        i, j = COMPS.index(ph["a"]), COMPS.index(ph["b"])
        t = stats.ttest_rel(y[:, i], y[:, j])
        assert abs(ph["t"]) == pytest.approx(abs(t.statistic))
        assert ph["p_bonferroni"] == pytest.approx(min(1.0, 3 * t.pvalue))
    fr = stats.friedmanchisquare(*(y[:, j] for j in range(k)))
    assert s["friedman"]["Q"] == pytest.approx(fr.statistic)
    assert s["friedman"]["p"] == pytest.approx(fr.pvalue)
    assert apa_rm_anova(a).startswith("F(")


def test_presence_index_and_json_cli(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    args = build_parser().parse_args(["analyze", "--responses", str(_csv(tmp_path)), "--json",
                                      "--report", str(tmp_path / "rep")])
    import io

    out = io.StringIO()
    assert run_study_command(args, stdout=out) == 0
    res = json.loads(out.getvalue())
    idx = {(r["participant"], r["comparison"]): r["index"] for r in res["presence_index"]}
    assert idx[("P4", "pedvr/decoupled")] == pytest.approx(13 / 3)
    assert set(res["scenarios"]["antipodal_circle"]) >= {"comparisons", "rm_anova", "posthoc_bonferroni",
                                                          "friedman", "n", "excluded"}
    md = (tmp_path / "rep" / "report.md").read_text()
    assert "| PedVR+G | Decoupled |" in md and "repeated-measures ANOVA" in md and "Friedman test: χ²(2)" in md
    svg = (tmp_path / "rep" / "histograms_antipodal_circle.svg").read_text()
    assert svg.count("<path") > 7 and "PedVR+G / Decoupled" in svg  # vector bars, text kept as text
    page = (tmp_path / "rep" / "report.html").read_text()
    assert page.count("<svg") == 1 and "<td class=\"num\">" in page and "Friedman test: χ²(2)" in page


def test_the_report_gives_the_one_sample_tests_confidence_intervals(tmp_path: Path) -> None:
    res = analyze(responses=_csv(tmp_path))
    from pedvr.study.report import write_report

    md = write_report(res, out=tmp_path / "rep").with_suffix(".md").read_text()
    for c, v in res["scenarios"]["antipodal_circle"]["comparisons"].items():
        lo, hi = v["one_sample_t_vs_4"]["ci95"]
        assert f"M = {v['mean']:.2f}, SD = {v['sd']:.2f}, 95 % CI [{lo:.2f}, {hi:.2f}]; against 4 t(5) = " in md, c


def test_incomplete_participant_is_left_out_of_the_anova(tmp_path: Path) -> None:
    f = _csv(tmp_path)
    lines = f.read_text().splitlines()
    f.write_text("\n".join(line for line in lines if not line.startswith("P6,antipodal_circle,pedvr+g/pedvr")) + "\n")
    s = analyze(responses=f)["scenarios"]["antipodal_circle"]
    assert s["excluded"] == ["P6"] and s["n"] == 5
    assert s["comparisons"]["pedvr+g/decoupled"]["n"] == 6


@pytest.mark.parametrize("text, message", [
    ("participant,scenario,comparison,response\nP1,s,a/b,3\n",
     r"missing column\(s\) question; expected a header participant,scenario,comparison,question,response"),
    ("participant,scenario,comparison,question,response\nP1,s,a/b,q1,9\n",
     r"responses\.csv:2: response = '9': expected an integer 1\.\.7 \(1 = left much better\)"),
    ("participant,scenario,comparison,question,response\nP1,s,a/b,q1,2.5\n",
     r"responses\.csv:2: response = '2\.5': expected an integer 1\.\.7"),
    ("participant,scenario,comparison,question,response\nP1,s,ab,q1,2\n",
     r"responses\.csv:2: comparison = 'ab': expected \"left/right\" condition names"),
    ("participant,scenario,comparison,question,response\nP1,s,a/b,q1,2\nP1,s,a/b,q1,3\n",
     r"responses\.csv:3: duplicate answer for participant P1, scenario s, comparison a/b, question q1 "
     r"\(first on line 2\)"),
    ("participant,scenario,comparison,question,response\n",
     r"responses\.csv: no answers \(only a header\)"),
    ("participant,scenario,comparison,question,response\nP1,s,a/b,q1,2\nP2,s,b/a,q1,2\n",
     r"scenario s: comparisons a/b and b/a are the same pair in both orientations"),
])
def test_bad_answer_files(tmp_path: Path, text: str, message: str) -> None:
    f = tmp_path / "responses.csv"
    f.write_text(text)
    with pytest.raises(AnswerError, match=message):
        read_responses_csv(f)


def test_bad_answer_file_lists_all_problems(tmp_path: Path) -> None:
    f = tmp_path / "responses.csv"
    f.write_text("participant,scenario,comparison,question,response\nP1,s,a/b,q1,0\n,s,a/b,q2,x\n")
    with pytest.raises(AnswerError) as exc:
        read_responses_csv(f)
    assert len(exc.value.problems) == 3
    assert f"{f}:3: participant = '': expected a non-empty value" in exc.value.problems


def test_analyze_cli_needs_exactly_one_source(tmp_path: Path) -> None:
    from pedvr.errors import UsageError

    with pytest.raises(UsageError, match=r"give a study database or --responses FILE\.csv \(exactly one\)"):
        run_study_command(build_parser().parse_args(["analyze"]))


def test_apa_p() -> None:
    assert apa_p(0.0004) == "p < .001" and apa_p(0.0034) == "p = .003" and apa_p(0.5) == "p = .500"


@pytest.mark.parametrize("user, agent, who", [(0.0, 0.3, "agent"), (0.3, 0.02, "user"), (0.2, 0.25, "both"),
                                              (0.05, 0.05, "neither"), (0.5, 0.2, "user")])
def test_who_gave_way(user: float, agent: float, who: str) -> None:
    assert who_gave_way(user, agent) == who


def test_csv_read_does_not_depend_on_column_order(tmp_path: Path) -> None:
    f = tmp_path / "r.csv"
    pd.DataFrame({"response": [2], "question": ["q"], "comparison": ["a/b"], "scenario": ["s"],
                  "participant": ["P1"]}).to_csv(f, index=False)
    df = read_responses_csv(f)
    assert list(df.columns) == ["participant", "scenario", "comparison", "question", "response"]
