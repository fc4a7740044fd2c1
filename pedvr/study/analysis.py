"""The analysis of PedVR §6.5 and Table 3, from a study database or a responses file.

Input: pairwise answers in long format, one row per answer, recoded to the
fixed orientation: ``participant, scenario, comparison, question, response``
with ``comparison = "left/right"`` (condition names) and ``response`` 1..7,
1 = the left condition much better.

Per scenario and comparison (Table 3, §6.5): ``n`` (participants),
``n_responses``, the frequencies of 1..7, ``mean`` and ``sd`` of the
participants' social-presence indices (the index is a participant's mean
over the items), the percentages of responses < 4, = 1 and = 4, Cronbach's
α over the items, and a one-sample t-test of the indices against 4 (no
difference). Per scenario: a one-way repeated-measures ANOVA of the index
over the comparisons with Mauchly's test and the Greenhouse–Geisser
correction, Bonferroni-corrected paired post hoc tests, and a Friedman test.
From a database also: SSQ subscale and total scores before, after and their
change, and the head-on corridor trajectories by responsibility (minimum
distance, lateral deviation, who gave way).

Statistics come from pingouin (GG-corrected RM-ANOVA, α, Bonferroni post hoc);
the tests check them against hand computations. Participants missing any
comparison of a scenario are left out of that scenario's ANOVA and Friedman
test (listwise, as SPSS does) and listed under ``excluded``.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pedvr.study.errors import AnswerError, ProtocolError, StudyStoreError
from pedvr.study.questionnaire import SSQ_ITEMS, Questionnaire, parse_questionnaire, score_ssq
from pedvr.study.scoring import score_answers
from pedvr.study.store import open_store

RESPONSE_COLUMNS = ("participant", "scenario", "comparison", "question", "response")
SCALE_MIN, SCALE_MAX, MIDPOINT = 1, 7, 4
GIVE_WAY_M = 0.10  # m of lateral deviation below which a walker is said not to have moved aside
GIVE_WAY_RATIO = 2.0  # one walker "gave way" when its deviation is at least this multiple of the other's
_CMP = re.compile(r"^[^/\s]+/[^/\s]+$")


# -- input -----------------------------------------------------------------------------------


def read_responses_csv(path: str | Path) -> pd.DataFrame:
    """Read and validate a long-format responses file; one :class:`AnswerError` lists every problem.

    Problems name the file, the line (header = line 1), the column and the value.
    """
    p = Path(path)
    if not p.is_file():
        raise AnswerError([f"{p}: no such responses file"])
    try:
        df = pd.read_csv(p, dtype=str, keep_default_na=False, skipinitialspace=True)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise AnswerError([f"{p}: not a readable CSV file: {str(exc).strip().splitlines()[0]}"]) from None
    missing = [c for c in RESPONSE_COLUMNS if c not in df.columns]
    if missing:
        raise AnswerError(
            [f"{p}: missing column(s) {', '.join(missing)}; expected a header {','.join(RESPONSE_COLUMNS)}"]
        )
    problems: list[str] = []
    seen: dict[tuple[str, str, str, str], int] = {}
    values: list[int] = []
    for k, row in enumerate(df.itertuples(index=False)):
        line = k + 2
        r = row._asdict()
        for col in ("participant", "scenario", "question"):
            if not str(r[col]).strip():
                problems.append(f"{p}:{line}: {col} = '': expected a non-empty value")
        cmp_ = str(r["comparison"]).strip()
        if not _CMP.match(cmp_) or cmp_.split("/")[0] == cmp_.split("/")[1]:
            problems.append(
                f'{p}:{line}: comparison = {cmp_!r}: expected "left/right" condition names, '
                "e.g. pedvr+g/decoupled"
            )
        raw = str(r["response"]).strip()
        try:
            v = int(raw)
            ok = SCALE_MIN <= v <= SCALE_MAX and str(v) == raw.lstrip("+")
        except ValueError:
            v, ok = 0, False
        if not ok:
            problems.append(
                f"{p}:{line}: response = {raw!r}: expected an integer {SCALE_MIN}..{SCALE_MAX} "
                f"({SCALE_MIN} = left much better)"
            )
        values.append(v)
        key = (str(r["participant"]).strip(), str(r["scenario"]).strip(), cmp_, str(r["question"]).strip())
        if key in seen:
            problems.append(
                f"{p}:{line}: duplicate answer for participant {key[0]}, scenario {key[1]}, "
                f"comparison {key[2]}, question {key[3]} (first on line {seen[key]})"
            )
        else:
            seen[key] = line
    if df.empty:
        problems.append(f"{p}: no answers (only a header)")
    if problems:
        raise AnswerError(problems)
    out = df[list(RESPONSE_COLUMNS)].apply(lambda s: s.str.strip())
    out["response"] = np.asarray(values, dtype=np.int64)
    _check_mirrored(out, source=str(p))
    return out


def _check_mirrored(df: pd.DataFrame, *, source: str) -> None:
    """A scenario must not name the same pair both ways round (``a/b`` and ``b/a``)."""
    problems = []
    for scen, g in df.groupby("scenario", sort=False):
        names = set(g["comparison"])
        for c in sorted(names):
            left, right = c.split("/")
            if f"{right}/{left}" in names and left < right:
                problems.append(
                    f"{source}: scenario {scen}: comparisons {c} and {right}/{left} are the same pair "
                    "in both orientations; recode to one fixed orientation"
                )
    if problems:
        raise AnswerError(problems)


def responses_from_db(db: str | Path) -> tuple[pd.DataFrame, list[str]]:
    """The recoded pairwise answers and the protocol's comparison order (Table 3's)."""
    from pedvr.study.export import responses_frame

    with open_store(db, read_only=True) as store:
        df = responses_frame(store)
        order = store.meta("comparisons") or []
    df["response"] = df["response"].astype(np.int64)
    return df, list(order)


# -- formatting ------------------------------------------------------------------------------


def apa_p(p: float) -> str:
    """APA p value: no leading zero, three decimals, ``p < .001`` below that."""
    if p is None or not np.isfinite(p):
        return "p = n/a"
    if p < 0.001:
        return "p < .001"
    return "p = " + f"{p:.3f}".lstrip("0")


def _num(x: float, digits: int = 2) -> str:
    return f"{x:.{digits}f}"


def _no0(x: float, digits: int = 2) -> str:
    s = f"{x:.{digits}f}"
    return s.replace("0.", ".", 1) if s.startswith(("0.", "-0.")) else s


def _f(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


# -- the computations ------------------------------------------------------------------------


def presence_index(df: pd.DataFrame) -> pd.DataFrame:
    """The social-presence index (PedVR §6.5): each participant's mean over the items."""
    return (
        df.groupby(["scenario", "comparison", "participant"], sort=False)["response"]
        .mean()
        .rename("index")
        .reset_index()
    )


def comparison_stats(g: pd.DataFrame) -> dict[str, Any]:
    """Table 3 row plus α and the one-sample test against the scale midpoint, for one comparison."""
    import pingouin as pg

    r = g["response"].to_numpy()
    idx = g.groupby("participant", sort=False)["response"].mean()
    freq = {str(v): int((r == v).sum()) for v in range(SCALE_MIN, SCALE_MAX + 1)}
    out: dict[str, Any] = {
        "left": g["comparison"].iloc[0].split("/")[0],
        "right": g["comparison"].iloc[0].split("/")[1],
        "n": int(idx.size),
        "n_responses": int(r.size),
        "frequencies": freq,
        "mean": _f(idx.mean()),
        "sd": _f(idx.std(ddof=1)) if idx.size > 1 else None,
        "mean_of_responses": _f(r.mean()),
        "pct_less_than_4": _f(100.0 * (r < MIDPOINT).mean()),
        "pct_equal_1": _f(100.0 * (r == SCALE_MIN).mean()),
        "pct_equal_4": _f(100.0 * (r == MIDPOINT).mean()),
    }
    wide = g.pivot_table(index="participant", columns="question", values="response", aggfunc="first").dropna()
    if wide.shape[1] >= 2 and wide.shape[0] >= 2:
        a, ci = pg.cronbach_alpha(data=wide)
        out["cronbach_alpha"] = _f(a)
        out["cronbach_alpha_ci95"] = [_f(ci[0]), _f(ci[1])]
        out["cronbach_alpha_n"] = int(wide.shape[0])
    else:
        out["cronbach_alpha"] = None
        out["cronbach_alpha_ci95"] = None
        out["cronbach_alpha_n"] = int(wide.shape[0])
    if idx.size >= 2 and float(idx.std(ddof=1)) > 0:
        t = pg.ttest(idx.to_numpy(), MIDPOINT)
        out["one_sample_t_vs_4"] = {
            "t": _f(t["T"].iloc[0]),
            "dof": int(t["dof"].iloc[0]),
            "p": _f(t["p_val"].iloc[0]),
            "cohen_d": _f(t["cohen_d"].iloc[0]),
            "ci95": mean_ci95(idx.to_numpy()),  # of the mean index (pingouin's CI95 is rounded to .01)
        }
    else:
        out["one_sample_t_vs_4"] = None
    return out


def mean_ci95(values: Any) -> list[float | None] | None:
    """The 95 % confidence interval of the mean of ``values``: mean ± t(.975, n − 1) · SD / √n.

    From scipy's one-sample t-test (the interval pingouin's ``ttest`` reports, at full precision:
    pingouin 0.7 rounds it to two decimals, too coarse for measures in metres). None for fewer than 2
    values; ``[mean, mean]`` when they are all equal.
    """
    from scipy import stats

    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size < 2:
        return None
    if np.allclose(v, v[0]):
        return [_f(v.mean()), _f(v.mean())]
    ci = stats.ttest_1samp(v, 0.0).confidence_interval(0.95)
    return [_f(ci.low), _f(ci.high)]


def within_tests(long: pd.DataFrame, levels: list[str]) -> dict[str, Any]:
    """Within-subjects tests of ``value`` over ``levels`` (``long``: columns subject, level, value).

    Per level the mean, SD, n and the 95 % confidence interval of the mean
    (:func:`mean_ci95`, over the subjects with that level); then over the subjects who have every level
    (listwise, as SPSS does; the others are listed under ``excluded``): a
    one-way repeated-measures ANOVA with Mauchly's test and the
    Greenhouse–Geisser correction, Bonferroni-corrected paired post hoc tests
    and a Friedman test. A subject with several values at one level (a trial
    run twice) counts with their mean. Tests need at least 2 levels and 3
    complete subjects; where every subject has the same value at every level
    there is nothing to test (``note`` says so and the tests are None).
    """
    import pingouin as pg

    wide = long.pivot_table(index="subject", columns="level", values="value", aggfunc="mean")
    wide = wide.reindex(columns=levels)
    complete = wide.dropna()
    excluded = sorted(str(s) for s in set(wide.index) - set(complete.index))
    out: dict[str, Any] = {
        "levels": {
            str(lv): {
                "n": int(wide[lv].notna().sum()),
                "mean": _f(wide[lv].mean()),
                "sd": _f(wide[lv].std(ddof=1)) if wide[lv].notna().sum() > 1 else None,
                "ci95": mean_ci95(wide[lv].dropna().to_numpy()),
            }
            for lv in levels
        },
        "n": int(complete.shape[0]),
        "excluded": excluded,
        "level_order": levels,
        "rm_anova": None,
        "posthoc_bonferroni": None,
        "friedman": None,
    }
    if len(levels) < 2 or complete.shape[0] < 3:
        have = complete.shape[0]
        out["note"] = f"needs at least 2 levels and 3 participants with all of them (have {have})"
        return out
    y = complete.to_numpy(dtype=float)
    if np.allclose(y, y[:, :1]):
        out["note"] = "no differences to test: every participant has the same value at every level"
        return out
    long_c = complete.reset_index().melt(id_vars="subject", var_name="level", value_name="value")
    with warnings.catch_warnings():  # pingouin 0.7 calls a pandas API deprecated in pandas 3.1; NaN warnings
        warnings.simplefilter("ignore")
        aov = pg.rm_anova(
            data=long_c, dv="value", within="level", subject="subject", correction=True, detailed=True
        )
        ph = pg.pairwise_tests(data=long_c, dv="value", within="level", subject="subject", padjust="bonf")
        fr = pg.friedman(data=long_c, dv="value", within="level", subject="subject")
    eff, err = aov.iloc[0], aov.iloc[1]
    k = len(levels)
    eps = _f(eff.get("eps")) if "eps" in aov.columns else 1.0
    if k == 2:
        eps = 1.0
    df1, df2 = float(eff["DF"]), float(err["DF"])
    p_gg = _f(eff["p_GG_corr"]) if "p_GG_corr" in aov.columns else _f(eff["p_unc"])
    ss_e, ss_r = float(eff["SS"]), float(err["SS"])
    out["rm_anova"] = {
        "F": _f(eff["F"]),
        "df1": df1,
        "df2": df2,
        "p": _f(eff["p_unc"]),
        "ss_effect": _f(ss_e),
        "ss_error": _f(ss_r),
        "partial_eta_squared": _f(ss_e / (ss_e + ss_r)) if ss_e + ss_r > 0 else None,
        "generalized_eta_squared": _f(eff["ng2"]),
        "mauchly_W": _f(eff["W_spher"]) if "W_spher" in aov.columns else None,
        "mauchly_p": _f(eff["p_spher"]) if "p_spher" in aov.columns else None,
        "sphericity": bool(eff["sphericity"]) if "sphericity" in aov.columns else True,
        "gg_epsilon": eps,
        "df1_gg": df1 * (eps or 1.0),
        "df2_gg": df2 * (eps or 1.0),
        "p_gg": p_gg,
    }
    if out["rm_anova"]["F"] is None:
        out["rm_anova"] = None
        out["note"] = "no ANOVA: no variation left within participants (F undefined)"
    out["posthoc_bonferroni"] = [
        {
            "a": str(r["A"]),
            "b": str(r["B"]),
            "t": _f(r["T"]),
            "dof": _f(r["dof"]),
            "p": _f(r["p_unc"]),
            "p_bonferroni": _f(r["p_corr"]),
            "hedges_g": _f(r["hedges"]),
        }
        for _, r in ph.iterrows()
    ]
    q = _f(fr["Q"].iloc[0])
    out["friedman"] = (
        None
        if q is None
        else {
            "Q": q,
            "dof": int(fr["ddof1"].iloc[0]),
            "p": _f(fr["p_unc"].iloc[0]),
            "kendall_W": _f(fr["W"].iloc[0]),
        }
    )
    return out


def scenario_tests(idx: pd.DataFrame, comparisons: list[str]) -> dict[str, Any]:
    """RM-ANOVA (Mauchly, GG), Bonferroni post hoc and Friedman over ``comparisons`` of one scenario."""
    long = idx.rename(columns={"participant": "subject", "comparison": "level", "index": "value"})
    out = within_tests(long[["subject", "level", "value"]], comparisons)
    out.pop("levels")
    out["comparison_order"] = out.pop("level_order")
    return out


def analyze_responses(df: pd.DataFrame, *, comparison_order: list[str] | None = None) -> dict[str, Any]:
    """Every §6.5 quantity for the pairwise answers in ``df`` (long format, validated).

    Comparisons are reported in ``comparison_order`` first, then in order of
    first appearance.
    """
    idx = presence_index(df)
    result: dict[str, Any] = {
        "n_participants": int(df["participant"].nunique()),
        "n_responses": int(len(df)),
        "scenarios": {},
    }
    for scen, g in df.groupby("scenario", sort=False):
        seen = list(dict.fromkeys(g["comparison"]))
        comps = [c for c in comparison_order or [] if c in seen] + [
            c for c in seen if c not in (comparison_order or [])
        ]
        per = {c: comparison_stats(g[g["comparison"] == c]) for c in comps}
        tests = scenario_tests(idx[idx["scenario"] == scen], comps)
        ps = [v["one_sample_t_vs_4"]["p"] for v in per.values() if v["one_sample_t_vs_4"]]
        for v in per.values():
            if v["one_sample_t_vs_4"]:
                v["one_sample_t_vs_4"]["p_bonferroni"] = min(
                    1.0, v["one_sample_t_vs_4"]["p"] * max(len(ps), 1)
                )
        result["scenarios"][str(scen)] = {"comparisons": per, **tests}
    result["presence_index"] = [
        {
            "participant": str(r.participant),
            "scenario": str(r.scenario),
            "comparison": str(r.comparison),
            "index": float(r.index),
        }
        for r in idx.itertuples(index=False)
    ]
    return result


SSQ_SCORES = ("nausea", "oculomotor", "disorientation", "total")


def paired_change(before: np.ndarray, after: np.ndarray) -> dict[str, Any]:
    """Paired tests of ``after`` against ``before`` (same participants, same order).

    ``t``: Student's paired t-test with Cohen's d_z (mean change / SD of the
    changes) and the 95 % CI of the mean change; ``wilcoxon``: the
    Wilcoxon signed-rank test (scipy's default: zero changes dropped, exact
    p for small samples without ties, else the normal approximation) with
    the matched-pairs rank-biserial correlation r = (W+ − W−) / (W+ + W−) as
    its effect size. Either is None where undefined (fewer than 2 pairs, no
    variation in the changes, or only zero changes).
    """
    from scipy import stats

    d = np.asarray(after, dtype=float) - np.asarray(before, dtype=float)
    out: dict[str, Any] = {
        "n": int(d.size),
        "mean_change": _f(d.mean()) if d.size else None,
        "t": None,
        "wilcoxon": None,
    }
    if d.size >= 2 and float(d.std(ddof=1)) > 0:
        t = stats.ttest_rel(after, before)
        ci = t.confidence_interval(0.95)
        out["t"] = {
            "t": _f(t.statistic),
            "dof": int(d.size - 1),
            "p": _f(t.pvalue),
            "cohen_dz": _f(d.mean() / d.std(ddof=1)),
            "ci95": [_f(ci.low), _f(ci.high)],
        }
    nz = d[d != 0]
    if nz.size >= 1:
        ranks = stats.rankdata(np.abs(nz))
        w_plus, w_minus = float(ranks[nz > 0].sum()), float(ranks[nz < 0].sum())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # scipy warns that the normal approximation is inexact for n < 10
            w = stats.wilcoxon(after, before)
        out["wilcoxon"] = {
            "W": _f(w.statistic),
            "p": _f(w.pvalue),
            "n_nonzero": int(nz.size),
            "rank_biserial": _f((w_plus - w_minus) / (w_plus + w_minus)),
        }
    return out


def ssq_scores(db: str | Path) -> dict[str, Any]:
    """SSQ scores per participant: the first administration (before), the last (after), and the change.

    ``summary`` has the mean, SD and n of each subscale and the total before,
    after and of the change; ``tests`` the paired tests of after against
    before (:func:`paired_change`) per subscale and the total, over the
    participants with both administrations complete.
    """
    with open_store(db, read_only=True) as store:
        df = pd.read_sql_query(
            "SELECT participant, step_index, item_number, raw_value FROM answers "
            "WHERE questionnaire_kind = 'ssq' ORDER BY participant, step_index, item_number",
            store.db,
        )
    per: list[dict[str, Any]] = []
    incomplete: list[str] = []
    for pid, g in df.groupby("participant", sort=True):
        admins = []
        for step, a in g.groupby("step_index", sort=True):
            items = {
                int(i): int(v)
                for i, v in zip(a["item_number"], a["raw_value"], strict=True)
                if v is not None and np.isfinite(v)
            }
            if len(items) == SSQ_ITEMS:
                admins.append(score_ssq(items).as_dict())
            else:
                incomplete.append(f"{pid} step {int(step)}")
        if len(admins) >= 1:
            row: dict[str, Any] = {"participant": str(pid), "before": admins[0]}
            if len(admins) >= 2:
                row["after"] = admins[-1]
                row["change"] = {k: admins[-1][k] - admins[0][k] for k in admins[0]}
            per.append(row)
    summary: dict[str, Any] = {}
    for phase in ("before", "after", "change"):
        rows = [r[phase] for r in per if phase in r]
        if rows:
            summary[phase] = {
                k: {
                    "mean": float(np.mean([r[k] for r in rows])),
                    "sd": float(np.std([r[k] for r in rows], ddof=1)) if len(rows) > 1 else None,
                    "n": len(rows),
                }
                for k in rows[0]
            }
    both = [r for r in per if "after" in r]
    tests = {
        k: paired_change(
            np.asarray([r["before"][k] for r in both]), np.asarray([r["after"][k] for r in both])
        )
        for k in SSQ_SCORES
    } if both else {}
    return {"participants": per, "summary": summary, "tests": tests, "incomplete_administrations": incomplete}


REFERENCE_RUN_M = 1.0  # m of initial travel that set a walker's reference direction


@dataclass(frozen=True)
class _Walk:
    xy: np.ndarray

    def lateral_deviation(self) -> float:
        """Largest distance from the walker's initial line of travel.

        The line passes through the first position, along the direction to the
        first position at least :data:`REFERENCE_RUN_M` away (walkers in the
        corridor start straight at each other). A walker that never got that
        far reports its largest distance from the start. Using the initial
        direction, not the start-to-end line, keeps a trial cut off mid-swerve
        from hiding the swerve.
        """
        a = self.xy[0]
        dist = np.linalg.norm(self.xy - a, axis=1)
        far = np.flatnonzero(dist >= REFERENCE_RUN_M)
        if far.size == 0:
            return float(dist.max())
        d = (self.xy[far[0]] - a) / dist[far[0]]
        rel = self.xy - a
        return float(np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]).max())


def who_gave_way(user_dev: float, agent_dev: float) -> str:
    """``user``, ``agent``, ``both`` or ``neither`` from the two lateral deviations (m).

    A walker moved aside when its deviation is at least :data:`GIVE_WAY_M`;
    when both did, the one whose deviation is at least :data:`GIVE_WAY_RATIO`
    times the other's gave way, else ``both``.
    """
    u, a = user_dev >= GIVE_WAY_M, agent_dev >= GIVE_WAY_M
    if u and a:
        if user_dev >= GIVE_WAY_RATIO * agent_dev:
            return "user"
        if agent_dev >= GIVE_WAY_RATIO * user_dev:
            return "agent"
        return "both"
    return "user" if u else "agent" if a else "neither"


def corridor_trajectories(db: str | Path) -> dict[str, Any]:
    """Head-on corridor trials (``sweep`` trials) by responsibility (PedVR §6.4).

    Per trial: minimum centre distance between the user and the agent that
    came closest, each one's lateral deviation from its initial line of
    travel (:meth:`_Walk.lateral_deviation`), who gave way, and the contacts
    between the participant and an agent (episodes, :mod:`pedvr.study.measures`).
    Trials skipped, aborted or interrupted are left out. ``trajectories``
    keeps the (x, y) paths for plots, in time order (the first point is the start).
    """
    from pedvr.study.measures import load_trials, measures

    with open_store(db, read_only=True) as store:
        trials = pd.read_sql_query(
            "SELECT trial_id, participant, scenario, responsibility, outcome FROM trials "
            "WHERE design = 'sweep' AND outcome IN ('reached_last_sphere', 'time_limit') ORDER BY trial_id",
            store.db,
        )
        rows: list[dict[str, Any]] = []
        paths: list[dict[str, Any]] = []
        contacts = {
            r.trial_id: measures["contacts"].compute(r)
            for r in load_trials(store, [int(t) for t in trials["trial_id"]])
        }
        for t in trials.itertuples(index=False):
            a = pd.read_sql_query(
                "SELECT frame, agent_id, is_user, x, y FROM agent_samples WHERE trial_id = ? "
                "ORDER BY frame, agent_id",
                store.db,
                params=(int(t.trial_id),),
            )
            if a.empty or not (a["is_user"] == 1).any() or not (a["is_user"] == 0).any():
                continue
            user = a[a["is_user"] == 1].set_index("frame")[["x", "y"]]
            others = a[a["is_user"] == 0]
            joined = others.merge(user, left_on="frame", right_index=True, suffixes=("", "_u"))
            dist = np.hypot(joined["x"] - joined["x_u"], joined["y"] - joined["y_u"])
            k = int(np.argmin(dist.to_numpy()))
            agent_id = int(joined["agent_id"].iloc[k])
            agent = others[others["agent_id"] == agent_id][["x", "y"]].to_numpy()
            u = user.to_numpy()
            ud, ad = _Walk(u).lateral_deviation(), _Walk(agent).lateral_deviation()
            rows.append(
                {
                    "trial_id": int(t.trial_id),
                    "participant": t.participant,
                    "responsibility": float(t.responsibility),
                    "outcome": t.outcome,
                    "agent_id": agent_id,
                    "min_distance_m": float(dist.iloc[k]),
                    "user_lateral_deviation_m": ud,
                    "agent_lateral_deviation_m": ad,
                    "gave_way": who_gave_way(ud, ad),
                    "contacts": contacts.get(int(t.trial_id)),
                }
            )
            paths.append(
                {
                    "trial_id": int(t.trial_id),
                    "responsibility": float(t.responsibility),
                    "user": u.tolist(),
                    "agent": agent.tolist(),
                }
            )
    by: dict[str, Any] = {}
    for rho in sorted({r["responsibility"] for r in rows}):
        rr = [r for r in rows if r["responsibility"] == rho]

        def m(key: str, rr: list[dict[str, Any]] = rr) -> dict[str, float | None]:
            v = np.asarray([r[key] for r in rr])
            return {"mean": float(v.mean()), "sd": float(v.std(ddof=1)) if v.size > 1 else None}

        by[f"{rho:g}"] = {
            "n": len(rr),
            "min_distance_m": m("min_distance_m"),
            "user_lateral_deviation_m": m("user_lateral_deviation_m"),
            "agent_lateral_deviation_m": m("agent_lateral_deviation_m"),
            "gave_way": {
                w: sum(r["gave_way"] == w for r in rr) for w in ("user", "agent", "both", "neither")
            },
            "contacts": int(sum(r["contacts"] or 0 for r in rr)),
            "trials_with_contact": int(sum(1 for r in rr if (r["contacts"] or 0) > 0)),
        }
    return {"trials": rows, "by_responsibility": by, "trajectories": paths}


# -- questionnaire scores, objective measures, the sample -----------------------------------------


def _questionnaire_definitions(store: Any) -> dict[str, Questionnaire]:
    """The questionnaires the database's sessions stored (meta ``questionnaire_files``), parsed."""
    import tomllib

    out: dict[str, Questionnaire] = {}
    for qid, text in (store.meta("questionnaire_files") or {}).items():
        try:
            out[qid] = parse_questionnaire(tomllib.loads(text), source=f"{store.path} (stored {qid})")
        except (ProtocolError, tomllib.TOMLDecodeError):
            continue  # a definition this pedvr cannot read: scored like an unknown likert questionnaire
    return out


def questionnaire_scores(db: str | Path) -> dict[str, Any]:
    """Scores of every scored questionnaire administration, compared across conditions.

    A questionnaire is scored by its published scoring (:mod:`pedvr.study.scoring`,
    from the definition the session stored in the database); a likert
    questionnaire with no stored definition by the mean of its recoded items.
    ``administrations`` has one row per (participant, step): the
    questionnaire, block, scenario, condition, label and its scores.
    ``by_block`` compares each score across the conditions of each block in
    which the questionnaire followed every trial (``after_each_trial``) with
    :func:`within_tests`; ``once`` describes questionnaires given without a
    condition (mean, SD, n per score).
    """
    with open_store(db, read_only=True) as store:
        defs = _questionnaire_definitions(store)
        ans = pd.read_sql_query(
            "SELECT participant, step_index, questionnaire, questionnaire_kind, item, block, scenario, "
            "condition, "
            "label, raw_value, recoded_value, text FROM answers "
            "WHERE questionnaire_kind IN ('likert', 'form') ORDER BY participant, step_index, answer_id",
            store.db,
        )
    rows: list[dict[str, Any]] = []
    scorers_used: dict[str, str] = {}
    for (pid, step), g in ans.groupby(["participant", "step_index"], sort=False):
        qid = str(g["questionnaire"].iloc[0])
        q = defs.get(qid)
        if q is not None and q.scoring:
            answers: dict[str, float | str | None] = {}
            for r in g.itertuples(index=False):
                text = str(r.text) if pd.notna(r.text) else None
                answers[str(r.item)] = float(r.raw_value) if pd.notna(r.raw_value) else text
            scores = score_answers(q, answers)
            scorers_used[qid] = q.scoring
        elif q is None and g["questionnaire_kind"].iloc[0] == "likert":
            vals = g["recoded_value"].dropna()
            scores = {"mean": float(vals.mean()) if len(vals) else None}
            scorers_used[qid] = "mean"
        else:
            continue
        first = g.iloc[0]
        rows.append(
            {
                "participant": str(pid),
                "step_index": int(step),
                "questionnaire": qid,
                "block": None if pd.isna(first["block"]) else str(first["block"]),
                "scenario": None if pd.isna(first["scenario"]) else str(first["scenario"]),
                "condition": None if pd.isna(first["condition"]) else str(first["condition"]),
                "label": None if pd.isna(first["label"]) else str(first["label"]),
                "scores": {k: _f(v) for k, v in scores.items()},
            }
        )
    by_block: dict[str, dict[str, Any]] = {}
    once: dict[str, dict[str, Any]] = {}
    for qid in dict.fromkeys(r["questionnaire"] for r in rows):
        mine = [r for r in rows if r["questionnaire"] == qid]
        names = list(dict.fromkeys(k for r in mine for k in r["scores"]))
        with_cond = [r for r in mine if r["condition"] is not None]
        if with_cond:
            for block in dict.fromkeys(r["block"] or r["scenario"] or "" for r in with_cond):
                rr = [r for r in with_cond if (r["block"] or r["scenario"] or "") == block]
                levels = list(dict.fromkeys(r["condition"] for r in rr))
                levels = _in_condition_order(levels)
                tests = {}
                for name in names:
                    long = pd.DataFrame(
                        {
                            "subject": [r["participant"] for r in rr],
                            "level": [r["condition"] for r in rr],
                            "value": [r["scores"].get(name) for r in rr],
                        }
                    ).dropna(subset=["value"])
                    if not long.empty:
                        tests[name] = within_tests(long, levels)
                by_block.setdefault(qid, {})[block] = {
                    "scenario": rr[0]["scenario"],
                    "levels": levels,
                    "scores": tests,
                }
        without = [r for r in mine if r["condition"] is None]
        if without:
            once[qid] = {
                name: _describe([r["scores"].get(name) for r in without]) for name in names
            }
    return {"scoring": scorers_used, "administrations": rows, "by_block": by_block, "once": once}


CONDITION_ORDER = ("decoupled", "pedvr", "pedvr+g")  # the report's column order where these appear


def _in_condition_order(levels: list[str]) -> list[str]:
    return [c for c in CONDITION_ORDER if c in levels] + [c for c in levels if c not in CONDITION_ORDER]


def _describe(values: list[float | None]) -> dict[str, Any]:
    v = np.asarray([x for x in values if x is not None], dtype=float)
    return {
        "n": int(v.size),
        "mean": _f(v.mean()) if v.size else None,
        "sd": _f(v.std(ddof=1)) if v.size > 1 else None,
        "min": _f(v.min()) if v.size else None,
        "max": _f(v.max()) if v.size else None,
    }


def _rho_level(rho: float) -> str:
    return f"rho={rho:g}"


def objective_measures(db: str | Path) -> dict[str, Any]:
    """Every registered measure (:mod:`pedvr.study.measures`) per block, compared across its levels.

    Trials that ran to their end (the last sphere or the time limit) of
    ``block`` designs are compared across conditions, and of ``sweep``
    designs across the swept responsibility (levels ``rho=0.25``, ...), each
    with :func:`within_tests`. ``trials`` is the per-trial table (as the
    export's ``trial_measures.tsv``), ``units`` and ``labels`` describe the measures.
    """
    from pedvr.study.measures import measure_names, measures, trial_measures

    with open_store(db, read_only=True) as store:
        tm = trial_measures(store)
    names = measure_names()
    done = tm[(tm["complete"] == 1) & tm["design"].isin(["block", "sweep"])].copy()
    by_block: dict[str, Any] = {}
    for block, g in done.groupby(done["block"].fillna(done["scenario"]), sort=False):
        design = str(g["design"].iloc[0])
        if design == "sweep":
            g = g.assign(level=[_rho_level(float(r)) for r in g["responsibility"]])
            levels = [_rho_level(r) for r in sorted(set(g["responsibility"].astype(float)))]
        else:
            g = g.assign(level=g["condition"])
            levels = _in_condition_order(list(dict.fromkeys(g["condition"])))
        tests = {}
        for name in names:
            long = pd.DataFrame(
                {"subject": g["participant"], "level": g["level"], "value": g[name]}
            ).dropna(subset=["value"])
            if not long.empty:
                tests[name] = within_tests(long, levels)
        by_block[str(block)] = {
            "design": design,
            "scenario": str(g["scenario"].iloc[0]),
            "levels": levels,
            "measures": tests,
        }
    trials = [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in tm.astype(object).where(tm.notna(), None).to_dict(orient="records")
    ]
    return {
        "units": {n: measures[n].unit for n in names},
        "labels": {n: measures[n].label for n in names},
        "by_block": by_block,
        "trials": trials,
    }


def sample_description(db: str | Path) -> dict[str, Any]:
    """Who took part: participants by status, sessions by status, aborts, and the demographics.

    ``protocols`` lists the protocol files the participants ran (by file name, with the number of
    participants each): one entry, unless the database was filled before pedvr refused a second
    protocol (:func:`pedvr.study.session.claim_database`).

    ``demographics`` summarises the answers to the questionnaire with id
    ``demographics`` (the shipped form): per item, numbers as n, mean, SD,
    minimum and maximum, choices as counts; ``no_answer`` counts the
    participants who reached the step and left the item unanswered.
    """
    with open_store(db, read_only=True) as store:
        parts = pd.read_sql_query(
            "SELECT participant, simulated, status FROM participants ORDER BY number", store.db
        )
        sess = pd.read_sql_query("SELECT participant, status FROM sessions", store.db)
        first = pd.read_sql_query(
            "SELECT participant, protocol_source FROM sessions WHERE session_id IN "
            "(SELECT MIN(session_id) FROM sessions GROUP BY participant) ORDER BY session_id",
            store.db,
        )
        aborts = pd.read_sql_query(
            "SELECT e.participant, e.step_index, e.utc, e.detail, st.step_key FROM events e "
            "LEFT JOIN steps st ON st.participant = e.participant AND st.step_index = e.step_index "
            "WHERE e.kind = 'abort' ORDER BY e.event_id",
            store.db,
        )
        demo = pd.read_sql_query(
            "SELECT participant, item, raw_value, text FROM answers WHERE questionnaire = 'demographics' "
            "ORDER BY answer_id",
            store.db,
        )
    by_status = {str(k): int(v) for k, v in parts["status"].value_counts().items()}
    # Protocol files by name (the same file given by another relative path is the same file), each with
    # the path its first participant ran it by.
    protocols: dict[str, dict[str, Any]] = {}
    for src in first["protocol_source"]:
        ran = protocols.setdefault(Path(str(src)).name, {"source": str(src), "participants": 0})
        ran["participants"] += 1
    demographics: dict[str, Any] = {}
    for item, g in demo.groupby("item", sort=False):
        nums = g["raw_value"].dropna()
        texts = g["text"].dropna()
        entry: dict[str, Any] = {"no_answer": int(len(g) - len(nums) - len(texts))}
        if len(nums):
            entry.update(_describe([float(v) for v in nums]))
        if len(texts):
            entry["counts"] = {str(k): int(v) for k, v in texts.value_counts().sort_index().items()}
        demographics[str(item)] = entry
    return {
        "participants": int(len(parts)),
        "simulated": int(parts["simulated"].sum()) if len(parts) else 0,
        "by_status": by_status,
        "finished": [str(p) for p in parts.loc[parts["status"] == "finished", "participant"]],
        "withdrawn": [str(p) for p in parts.loc[parts["status"] == "withdrawn", "participant"]],
        "not_finished": [str(p) for p in parts.loc[parts["status"] == "in_progress", "participant"]],
        "sessions": {str(k): int(v) for k, v in sess["status"].value_counts().items()},
        "protocols": list(protocols.values()),
        "aborts": [
            {
                "participant": str(r.participant),
                "step": None if pd.isna(r.step_key) else str(r.step_key),
                "utc": str(r.utc),
                "detail": None if pd.isna(r.detail) else str(r.detail),
            }
            for r in aborts.itertuples(index=False)
        ],
        "demographics": demographics,
    }


def response_times(db: str | Path) -> dict[str, Any]:
    """Response times per questionnaire (seconds from the item shown to the answer confirmed):
    n, median and quartiles over all its answers, and the median per item.

    Only people's answers: a simulated participant answers as soon as it is asked (its times are
    0.00 s and say nothing), so its answers are left out; the report says how many were.
    """
    with open_store(db, read_only=True) as store:
        df = pd.read_sql_query(
            "SELECT a.questionnaire, a.item, a.response_time_s FROM answers a "
            "JOIN participants p USING (participant) "
            "WHERE a.response_time_s IS NOT NULL AND p.simulated = 0 ORDER BY a.answer_id",
            store.db,
        )
    out: dict[str, Any] = {}
    for qid, g in df.groupby("questionnaire", sort=False):
        v = g["response_time_s"].to_numpy(dtype=float)
        out[str(qid)] = {
            "n": int(v.size),
            "median_s": _f(np.median(v)),
            "q1_s": _f(np.percentile(v, 25)),
            "q3_s": _f(np.percentile(v, 75)),
            "items": {
                str(k): _f(x) for k, x in g.groupby("item", sort=False)["response_time_s"].median().items()
            },
        }
    return out


def analyze(*, db: str | Path | None = None, responses: str | Path | None = None) -> dict[str, Any]:
    """The whole analysis. Exactly one of ``db`` and ``responses`` (a CSV file).

    From a database every section is computed from what it holds; a database
    with only some kinds of data (only the SSQ, only one questionnaire, only
    trials) gets those sections. Only a database with no answers and no trial
    that ran to its end is an error (nothing to analyse yet), and a damaged
    one (:class:`~pedvr.study.errors.DamagedStoreError`).
    """
    if (db is None) == (responses is None):
        from pedvr.errors import UsageError

        raise UsageError("analyze: give a study database or --responses FILE.csv, not both")
    if responses is not None:
        df = read_responses_csv(responses)
        out = analyze_responses(df)
        out["source"] = {"responses": str(responses)}
        return out
    assert db is not None
    with open_store(db, read_only=True) as store:
        store.check_intact()  # a damaged database is one error, before any section reads it
    df, order = responses_from_db(db)
    sample = sample_description(db)
    if df.empty:
        out = {
            "n_participants": sample["participants"],
            "n_responses": 0,
            "scenarios": {},
            "presence_index": [],
        }
    else:
        out = analyze_responses(df, comparison_order=order)
        out["n_participants"] = sample["participants"]
    out["source"] = {"database": str(db)}
    out["sample"] = sample
    out["ssq"] = ssq_scores(db)
    out["questionnaires"] = questionnaire_scores(db)
    out["measures"] = objective_measures(db)
    out["corridor"] = corridor_trajectories(db)
    out["response_times"] = response_times(db)
    with open_store(db, read_only=True) as store:
        n_answers = store.query("SELECT COUNT(*) AS n FROM answers")[0]["n"]
    if not n_answers and not out["measures"]["by_block"] and not any(
        t["complete"] for t in out["measures"]["trials"]
    ):
        raise StudyStoreError(f"{db}: nothing to analyse yet: no answers and no trial that ran to its end")
    return out


# -- APA sentences ---------------------------------------------------------------------------


def apa_rm_anova(a: dict[str, Any]) -> str:
    if a["sphericity"] or a["gg_epsilon"] in (None, 1.0):
        head = f"F({_num(a['df1'], 0)}, {_num(a['df2'], 0)}) = {_num(a['F'])}, {apa_p(a['p'])}"
    else:
        head = (
            f"F({_num(a['df1_gg'], 3)}, {_num(a['df2_gg'], 3)}) = {_num(a['F'])}, {apa_p(a['p_gg'])} "
            f"(Greenhouse–Geisser, ε = {_no0(a['gg_epsilon'], 3)})"
        )
    mauchly = (
        ""
        if a["mauchly_W"] is None
        else f"; Mauchly's W = {_no0(a['mauchly_W'], 3)}, {apa_p(a['mauchly_p'])}"
    )
    eta = "n/a" if a["partial_eta_squared"] is None else _no0(a["partial_eta_squared"])
    return f"{head}, η²p = {eta}{mauchly}"


def apa_t(t: dict[str, Any], *, p_key: str = "p") -> str:
    return f"t({t['dof']:g}) = {_num(t['t'])}, {apa_p(t[p_key])}"


def apa_friedman(f: dict[str, Any]) -> str:
    return f"χ²({f['dof']}) = {_num(f['Q'])}, {apa_p(f['p'])}, Kendall's W = {_no0(f['kendall_W'])}"


def apa_paired_t(t: dict[str, Any]) -> str:
    """A paired t-test from :func:`paired_change`: ``t(5) = 2.31, p = .069, d_z = 0.94``."""
    return f"t({t['dof']:g}) = {_num(t['t'])}, {apa_p(t['p'])}, d_z = {_num(t['cohen_dz'])}"


def apa_wilcoxon(w: dict[str, Any]) -> str:
    """A Wilcoxon signed-rank test from :func:`paired_change`: ``W = 3.00, p = .250, r = .60``."""
    return f"W = {_num(w['W'])}, {apa_p(w['p'])}, r = {_no0(w['rank_biserial'])}"
