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

from pedvr.study.errors import AnswerError, StudyStoreError
from pedvr.study.questionnaire import SSQ_ITEMS, score_ssq
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

    with open_store(db, must_exist=True) as store:
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
            "ci95": [_f(v) for v in t["CI95"].iloc[0]],
        }
    else:
        out["one_sample_t_vs_4"] = None
    return out


def scenario_tests(idx: pd.DataFrame, comparisons: list[str]) -> dict[str, Any]:
    """RM-ANOVA (Mauchly, GG), Bonferroni post hoc and Friedman over ``comparisons`` of one scenario."""
    import pingouin as pg

    wide = idx.pivot_table(index="participant", columns="comparison", values="index", aggfunc="first")
    wide = wide.reindex(columns=comparisons)
    complete = wide.dropna()
    excluded = sorted(set(wide.index) - set(complete.index))
    out: dict[str, Any] = {"n": int(complete.shape[0]), "excluded": excluded, "comparison_order": comparisons}
    if len(comparisons) < 2 or complete.shape[0] < 3:
        out["rm_anova"] = out["posthoc_bonferroni"] = out["friedman"] = None
        out["note"] = "needs at least 2 comparisons and 3 participants with all of them"
        return out
    long = complete.reset_index().melt(id_vars="participant", var_name="comparison", value_name="index")
    with warnings.catch_warnings():  # pingouin 0.7 calls a pandas API deprecated in pandas 3.1
        warnings.filterwarnings("ignore", module="pingouin")
        aov = pg.rm_anova(
            data=long, dv="index", within="comparison", subject="participant", correction=True, detailed=True
        )
    eff, err = aov.iloc[0], aov.iloc[1]
    k = len(comparisons)
    eps = _f(eff.get("eps")) if "eps" in aov.columns else 1.0
    if k == 2:
        eps = 1.0
    df1, df2 = float(eff["DF"]), float(err["DF"])
    p_gg = _f(eff["p_GG_corr"]) if "p_GG_corr" in aov.columns else _f(eff["p_unc"])
    out["rm_anova"] = {
        "F": _f(eff["F"]),
        "df1": df1,
        "df2": df2,
        "p": _f(eff["p_unc"]),
        "ss_effect": _f(eff["SS"]),
        "ss_error": _f(err["SS"]),
        "partial_eta_squared": _f(eff["SS"] / (eff["SS"] + err["SS"])),
        "generalized_eta_squared": _f(eff["ng2"]),
        "mauchly_W": _f(eff["W_spher"]) if "W_spher" in aov.columns else None,
        "mauchly_p": _f(eff["p_spher"]) if "p_spher" in aov.columns else None,
        "sphericity": bool(eff["sphericity"]) if "sphericity" in aov.columns else True,
        "gg_epsilon": eps,
        "df1_gg": df1 * (eps or 1.0),
        "df2_gg": df2 * (eps or 1.0),
        "p_gg": p_gg,
    }
    ph = pg.pairwise_tests(data=long, dv="index", within="comparison", subject="participant", padjust="bonf")
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
    fr = pg.friedman(data=long, dv="index", within="comparison", subject="participant")
    out["friedman"] = {
        "Q": _f(fr["Q"].iloc[0]),
        "dof": int(fr["ddof1"].iloc[0]),
        "p": _f(fr["p_unc"].iloc[0]),
        "kendall_W": _f(fr["W"].iloc[0]),
    }
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


def ssq_scores(db: str | Path) -> dict[str, Any]:
    """SSQ scores per participant: the first administration (before), the last (after), and the change."""
    with open_store(db, must_exist=True) as store:
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
    return {"participants": per, "summary": summary, "incomplete_administrations": incomplete}


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
    travel (:meth:`_Walk.lateral_deviation`), and who gave way. Trials skipped, aborted or
    interrupted are left out. ``trajectories`` keeps the (x, y) paths for plots.
    """
    with open_store(db, must_exist=True) as store:
        trials = pd.read_sql_query(
            "SELECT trial_id, participant, scenario, responsibility, outcome FROM trials "
            "WHERE design = 'sweep' AND outcome IN ('reached_last_sphere', 'time_limit') ORDER BY trial_id",
            store.db,
        )
        rows: list[dict[str, Any]] = []
        paths: list[dict[str, Any]] = []
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
        }
    return {"trials": rows, "by_responsibility": by, "trajectories": paths}


def analyze(*, db: str | Path | None = None, responses: str | Path | None = None) -> dict[str, Any]:
    """The whole analysis. Exactly one of ``db`` and ``responses`` (a CSV file)."""
    if (db is None) == (responses is None):
        from pedvr.errors import UsageError

        raise UsageError("analyze: give a study database or --responses FILE.csv, not both")
    if responses is not None:
        df = read_responses_csv(responses)
        out = analyze_responses(df)
        out["source"] = {"responses": str(responses)}
        return out
    assert db is not None
    df, order = responses_from_db(db)
    if df.empty:
        raise StudyStoreError(f"{db}: no pairwise answers to analyse yet")
    out = analyze_responses(df, comparison_order=order)
    out["source"] = {"database": str(db)}
    out["ssq"] = ssq_scores(db)
    out["corridor"] = corridor_trajectories(db)
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
    return f"{head}, η²p = {_no0(a['partial_eta_squared'])}{mauchly}"


def apa_t(t: dict[str, Any], *, p_key: str = "p") -> str:
    return f"t({t['dof']:g}) = {_num(t['t'])}, {apa_p(t[p_key])}"


def apa_friedman(f: dict[str, Any]) -> str:
    return f"χ²({f['dof']}) = {_num(f['Q'])}, {apa_p(f['p'])}, Kendall's W = {_no0(f['kendall_W'])}"
