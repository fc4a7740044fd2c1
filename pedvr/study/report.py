"""The analysis report: ``report.html`` (the main report, vector figures inline) and ``report.md``.

Both files are rendered from one list of blocks (headings, paragraphs,
bullet lists, tables, figures), so they say the same thing. Figures are SVG
files written beside them (matplotlib's SVG backend, text kept as text,
fixed ids and no date, so the same analysis gives the same bytes); the HTML
embeds them inline, the Markdown links them.

Sections, each present when the data is: the sample (participants by status,
aborted sessions, demographics); per scenario the pairwise responses laid out
as PedVR Table 3 with Cronbach's α, the repeated-measures ANOVA with Mauchly's
test and the Greenhouse–Geisser correction, Bonferroni post hoc tests with
Hedges' g, one-sample tests against 4 with the 95 % CI of the mean and
Cohen's d, and the Friedman test, in APA style, with histograms like PedVR
Fig. 6; questionnaire scores (IPQ, co-presence, NASA-TLX, ...) by condition
with the same tests; questionnaires given once; the objective measures by
condition (and by responsibility in a sweep) with the same tests and a figure
per block; the SSQ before and after with paired t and Wilcoxon tests; the
head-on corridor by responsibility (contacts, three decimals) with trajectory
plots marking each start and the direction of travel; response times per
questionnaire (people only: a simulated participant answers at once).

The per-condition figures draw each mean with its 95 % confidence interval
(t distribution over the participants with that condition), and say so in
the figure and the text; tables give M (SD). A dry run (every participant
simulated) says so at the top.
"""

from __future__ import annotations

import html
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from pedvr.study.analysis import (
    MIDPOINT,
    SCALE_MAX,
    SCALE_MIN,
    SSQ_SCORES,
    apa_friedman,
    apa_p,
    apa_paired_t,
    apa_rm_anova,
    apa_t,
    apa_wilcoxon,
)
from pedvr.study.output import prepare_folder, write_file

PAIRWISE_LABELS = (
    "Left much\nbetter",
    "Left\nbetter",
    "Left slightly\nbetter",
    "No\ndifference",
    "Right slightly\nbetter",
    "Right\nbetter",
    "Right much\nbetter",
)
NAMES = {"decoupled": "Decoupled", "pedvr": "PedVR", "pedvr+g": "PedVR+G"}
BLUE, GREY, RED = "#3b6fb6", "#999999", "#c8553d"
LEVEL_COLORS = ("#3b6fb6", "#c8553d", "#4f9a5a", "#8e5ea2", "#d39b2a", "#5a5a5a")
SCORE_LABELS = {
    "general_presence": "general presence (G1)",
    "spatial_presence": "spatial presence (SP)",
    "involvement": "involvement (INV)",
    "experienced_realism": "experienced realism (REAL)",
    "sus_count": "SUS count (answers of 6-7)",
    "sus_mean": "mean of the 6 items",
    "raw_tlx": "raw TLX",
    "weighted_tlx": "weighted TLX",
    "copresence": "co-presence",
    "sus_score": "SUS score (0-100)",
    "mean": "mean of the items",
}


CI_NAME = "95 % confidence interval"
CI_METHOD = (
    "Figures show each condition's mean and its 95 % confidence interval (t distribution with n − 1 "
    "degrees of freedom over the participants with that condition; not the SD). The intervals include "
    "the differences between participants, so two that overlap can still differ within participants: "
    "the tests say whether they do."
)


def _ci(ci: list[float | None] | None, d: int = 2) -> str:
    return "–" if not ci or ci[0] is None or ci[1] is None else f"[{ci[0]:.{d}f}, {ci[1]:.{d}f}]"


def _name(c: str) -> str:
    if c.startswith("rho="):
        return f"ρ = {c[4:]}"
    return NAMES.get(c, c)


def _cmp_name(c: str) -> str:
    left, right = c.split("/")
    return f"{_name(left)} / {_name(right)}"


def _fmt(v: Any, d: int = 2) -> str:
    return "–" if v is None else f"{v:.{d}f}"


# -- the document model ---------------------------------------------------------------------------


@dataclass(frozen=True)
class Heading:
    level: int
    text: str


@dataclass(frozen=True)
class Para:
    text: str


@dataclass(frozen=True)
class Bullets:
    items: tuple[str, ...]


@dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    right: tuple[bool, ...] = ()  # per column: right-aligned (numbers)


@dataclass(frozen=True)
class Figure:
    file: str  # an SVG file in the report folder
    alt: str


Block = Heading | Para | Bullets | Table | Figure


@dataclass
class _Doc:
    out: Path
    blocks: list[Block] = field(default_factory=list)
    figures: list[str] = field(default_factory=list)

    def add(self, *blocks: Block) -> None:
        self.blocks.extend(blocks)

    def figure(self, name: str, alt: str, draw: Callable[[Path], object]) -> None:
        path = self.out / name
        write_file(path, draw)
        self.figures.append(name)
        self.blocks.append(Figure(file=name, alt=alt))


# -- figures --------------------------------------------------------------------------------------


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


# Text stays text (smaller files, selectable, searchable); fixed element ids (same data, same bytes).
SVG_RC = {"svg.fonttype": "none", "svg.hashsalt": "pedvr-report"}


def _save(fig: Any, path: Path) -> None:
    plt = _plt()
    with plt.rc_context(SVG_RC):
        fig.savefig(path, format="svg", metadata={"Date": None})


def _fig_histograms(scen: str, comps: dict[str, Any], path: Path) -> None:
    plt = _plt()
    fig, axes = plt.subplots(1, len(comps), figsize=(4.2 * len(comps), 3.6), sharey=True, squeeze=False)
    for ax, (c, s) in zip(axes[0], comps.items(), strict=True):
        n = max(s["n_responses"], 1)
        pct = [100.0 * s["frequencies"][str(v)] / n for v in range(SCALE_MIN, SCALE_MAX + 1)]
        colors = [
            BLUE if v < MIDPOINT else GREY if v == MIDPOINT else RED for v in range(SCALE_MIN, SCALE_MAX + 1)
        ]
        ax.bar(range(SCALE_MIN, SCALE_MAX + 1), pct, color=colors)
        ax.set_xticks(range(SCALE_MIN, SCALE_MAX + 1))
        ax.set_xticklabels(
            PAIRWISE_LABELS
            if SCALE_MAX - SCALE_MIN == 6
            else [str(v) for v in range(SCALE_MIN, SCALE_MAX + 1)],
            fontsize=6,
        )
        ax.set_title(f"{_cmp_name(c)}\n(n = {s['n']}, {s['n_responses']} responses)", fontsize=9)
        ax.set_xlabel("response")
    axes[0][0].set_ylabel("% of responses")
    fig.suptitle(f"{scen}: preference between conditions (cf. PedVR Fig. 6)", fontsize=10)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def _arrows(ax: Any, xy: Sequence[Sequence[float]], color: str, every_m: float = 1.5) -> None:
    """Arrowheads along a path every ``every_m`` metres, pointing the way it was walked."""
    import numpy as np

    p = np.asarray(xy, dtype=float)
    if len(p) < 2:
        return
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 0:
        return
    marks = [int(np.searchsorted(s, d)) for d in np.arange(every_m / 2, s[-1] - every_m / 4, every_m)]
    marks.append(int(np.flatnonzero(seg > 0)[-1]) + 1)  # and one at the end of every path, however short
    for k in marks:
        k = min(max(k, 1), len(p) - 1)
        if seg[k - 1] <= 0:
            continue
        ax.annotate(
            "",
            xy=tuple(p[k]),
            xytext=tuple(p[k - 1]),
            arrowprops={"arrowstyle": "-|>", "color": color, "lw": 0.8, "mutation_scale": 9},
        )


def _fig_corridor(corridor: dict[str, Any], path: Path) -> None:
    plt = _plt()
    rhos = sorted({t["responsibility"] for t in corridor["trajectories"]})
    fig, axes = plt.subplots(len(rhos), 1, figsize=(8, 2.0 * len(rhos)), sharex=True, squeeze=False)
    for ax, rho in zip(axes[:, 0], rhos, strict=True):
        for t in corridor["trajectories"]:
            if t["responsibility"] != rho:
                continue
            for who, color in (("user", BLUE), ("agent", RED)):
                p = t[who]
                ax.plot([q[0] for q in p], [q[1] for q in p], color=color, lw=1, alpha=0.8)
                ax.plot([p[0][0]], [p[0][1]], marker="o", ms=5, mfc="white", mec=color, mew=1.2, ls="none")
                _arrows(ax, p, color)
        ax.set_title(
            f"responsibility {rho:g}: blue the participant, red the agent; ○ start, arrows the direction",
            fontsize=9,
        )
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal", adjustable="datalim")
    axes[-1, 0].set_xlabel("x (m)")
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def _fig_levels(title: str, panels: list[tuple[str, list[str], dict[str, Any]]], path: Path) -> None:
    """Mean and its 95 % confidence interval per level (:func:`~pedvr.study.analysis.mean_ci95`), one panel
    per variable: ``(panel title, levels, within_tests result)``. A level with one value has no interval
    (a bare point)."""
    plt = _plt()
    cols = min(4, len(panels))
    rows = (len(panels) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 2.6 * rows), squeeze=False)
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax, (name, levels, res) in zip(axes.ravel(), panels, strict=False):
        for k, lv in enumerate(levels):
            d = res["levels"].get(lv, {})
            if d.get("mean") is None:
                continue
            ci = d.get("ci95") or [d["mean"], d["mean"]]
            ax.errorbar(
                [k],
                [d["mean"]],
                yerr=[[d["mean"] - ci[0]], [ci[1] - d["mean"]]],
                fmt="o",
                color=LEVEL_COLORS[k % len(LEVEL_COLORS)],
                capsize=3,
            )
        ax.set_xticks(range(len(levels)))
        ax.set_xticklabels([_name(lv) for lv in levels], fontsize=7)
        ax.set_xlim(-0.5, len(levels) - 0.5)
        ax.set_title(name, fontsize=8)
        ax.tick_params(axis="y", labelsize=7)
        ax.ticklabel_format(axis="y", useOffset=False)  # values as they are, not "1e-5 + 4.95e-1"
    fig.suptitle(f"{title}: mean and {CI_NAME}", fontsize=10)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)


def _slug(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", s)


# -- sections -------------------------------------------------------------------------------------


def _sample(doc: _Doc, result: dict[str, Any]) -> None:
    s = result.get("sample")
    if not s:
        return
    st = s["by_status"]
    doc.add(Heading(2, "Sample"))
    parts = [
        f"{s['participants']} participants registered ({s['simulated']} of them simulated): "
        f"{st.get('finished', 0)} finished the protocol, {st.get('withdrawn', 0)} withdrew (declined "
        "consent), "
        f"{st.get('in_progress', 0)} have not finished."
    ]
    sess = s["sessions"]
    if sess:
        parts.append("Sessions: " + ", ".join(f"{v} {k}" for k, v in sorted(sess.items())) + ".")
    protocols = s.get("protocols") or []
    if len(protocols) > 1:
        parts.append(
            f"Participants ran under {len(protocols)} protocol files ("
            + "; ".join(f"{p['source']}: {p['participants']}" for p in protocols)
            + "): one database should hold one study; analyse each protocol's participants apart."
        )
    doc.add(Para(" ".join(parts)))
    lists = []
    if s["withdrawn"]:
        lists.append(f"Withdrawn: {', '.join(s['withdrawn'])}.")
    if s["not_finished"]:
        lists.append(f"Not finished (in progress or aborted, resumable): {', '.join(s['not_finished'])}.")
    for a in s["aborts"]:
        lists.append(
            f"Session of {a['participant']} aborted at {a['step'] or 'the start'} ({a['utc']}): "
            f"{a['detail'] or 'by the experimenter'}."
        )
    if lists:
        doc.add(Bullets(tuple(lists)))
    demo = s["demographics"]
    if demo:
        rows = []
        for item, d in demo.items():
            if "mean" in d:
                rows.append(
                    (
                        item,
                        str(d["n"]),
                        f"M = {_fmt(d['mean'], 1)}, SD = {_fmt(d['sd'], 1)}, "
                        f"range {_fmt(d['min'], 0)}–{_fmt(d['max'], 0)}",
                        str(d["no_answer"]),
                    )
                )
            if "counts" in d:
                rows.append(
                    (
                        item,
                        str(sum(d["counts"].values())),
                        ", ".join(f"{k}: {v}" for k, v in d["counts"].items()),
                        str(d["no_answer"]),
                    )
                )
        doc.add(
            Heading(3, "Demographics"),
            Table(("item", "n", "summary", "no answer"), tuple(rows), (False, True, False, True)),
        )


def _pairwise(doc: _Doc, result: dict[str, Any]) -> None:
    for scen, s in result["scenarios"].items():
        per = s["comparisons"]
        rows = []
        for v in per.values():
            rows.append(
                (
                    _name(v["left"]),
                    _name(v["right"]),
                    *(str(v["frequencies"][str(k)]) for k in range(SCALE_MIN, SCALE_MAX + 1)),
                    str(v["n"]),
                    _fmt(v["mean"]),
                    f"± {_fmt(v['sd'])}",
                    _fmt(v["pct_less_than_4"], 1),
                    _fmt(v["pct_equal_1"], 1),
                    _fmt(v["pct_equal_4"], 1),
                    _fmt(v["cronbach_alpha"]),
                )
            )
        header = (
            "Left",
            "Right",
            *(str(v) for v in range(SCALE_MIN, SCALE_MAX + 1)),
            "n",
            "mean",
            "SD",
            "% < 4",
            "% = 1",
            "% = 4",
            "α",
        )
        doc.add(
            Heading(2, f"{scen}: pairwise social presence"),
            Heading(3, "Responses (cf. PedVR Table 3)"),
            Table(header, tuple(rows), (False, False, *([True] * (len(header) - 2)))),
        )
        doc.figure(
            f"histograms_{_slug(scen)}.svg",
            f"{scen} histograms",
            partial(_fig_histograms, scen, per),
        )
        doc.add(Heading(3, "Statistics"))
        lines: list[str] = []
        alphas = [v["cronbach_alpha"] for v in per.values() if v["cronbach_alpha"] is not None]
        if alphas:
            each = ", ".join(
                f"{_cmp_name(c)}: α = {v['cronbach_alpha']:.2f}"
                for c, v in per.items()
                if v["cronbach_alpha"] is not None
            )
            lines.append(
                f"Reliability of the index: Cronbach's α from {min(alphas):.2f} to {max(alphas):.2f} "
                f"({each})."
            )
        a = s.get("rm_anova")
        if a:
            lines.append(
                f"One-way repeated-measures ANOVA of the index over the comparisons (n = {s['n']}): "
                f"{apa_rm_anova(a)}."
            )
            for ph in s["posthoc_bonferroni"] or []:
                lines.append(
                    f"Post hoc (paired, Bonferroni) {_cmp_name(ph['a'])} vs {_cmp_name(ph['b'])}: "
                    f"t({ph['dof']:g}) = {_fmt(ph['t'])}, {apa_p(ph['p_bonferroni'])}, "
                    f"Hedges' g = {_fmt(ph['hedges_g'])}."
                )
        else:
            lines.append(f"No ANOVA: {s.get('note', 'not enough data')}.")
        if s.get("friedman"):
            lines.append(f"Friedman test: {apa_friedman(s['friedman'])}.")
        for c, v in per.items():
            t = v["one_sample_t_vs_4"]
            if t:
                lines.append(
                    f"{_cmp_name(c)}: M = {v['mean']:.2f}, SD = {_fmt(v['sd'])}, 95 % CI "
                    f"{_ci(t['ci95'])}; against 4 "
                    f"{apa_t(t)} (Bonferroni over comparisons: {apa_p(t['p_bonferroni'])}), "
                    f"d = {t['cohen_d']:.2f}."
                )
        if s.get("excluded"):
            lines.append(f"Left out of the ANOVA (missing a comparison): {', '.join(s['excluded'])}.")
        doc.add(Bullets(tuple(lines)))


def _tests_line(name: str, res: dict[str, Any]) -> str:
    parts = []
    if res.get("rm_anova"):
        parts.append(f"RM-ANOVA {apa_rm_anova(res['rm_anova'])}")
    if res.get("friedman"):
        parts.append(f"Friedman {apa_friedman(res['friedman'])}")
    if not parts:
        return f"{name}: {res.get('note', 'no test')}."
    line = f"{name} (n = {res['n']}): " + "; ".join(parts) + "."
    sig = [ph for ph in res.get("posthoc_bonferroni") or [] if ph["p_bonferroni"] is not None]
    if sig:
        line += (
            " Post hoc (paired, Bonferroni): "
            + "; ".join(
                f"{_name(ph['a'])} vs {_name(ph['b'])} t({ph['dof']:g}) = {_fmt(ph['t'])}, "
                f"{apa_p(ph['p_bonferroni'])}, Hedges' g = {_fmt(ph['hedges_g'])}"
                for ph in sig
            )
            + "."
        )
    if res.get("excluded"):
        line += f" Left out (missing a level): {', '.join(res['excluded'])}."
    return line


def _levels_table(
    first: str, levels: list[str], named: list[tuple[str, dict[str, Any]]], digits: int
) -> Table:
    rows = []
    for name, res in named:
        cells = []
        for lv in levels:
            d = res["levels"].get(lv, {})
            cells.append(
                "–" if d.get("mean") is None else f"{d['mean']:.{digits}f} ({_fmt(d.get('sd'), digits)})"
            )
        rows.append((name, *cells, str(res["n"])))
    return Table(
        (first, *(f"{_name(lv)} M (SD)" for lv in levels), "n (all levels)"),
        tuple(rows),
        (False, *([True] * (len(levels) + 1))),
    )


def _scoring_title(qs: dict[str, Any], qid: str) -> str:
    from pedvr.study.scoring import scorers

    name = qs["scoring"].get(qid, "")
    return scorers[name].title if name in scorers else name


def _questionnaires(doc: _Doc, result: dict[str, Any]) -> None:
    qs = result.get("questionnaires")
    if not qs or not (qs["by_block"] or qs["once"]):
        return
    doc.add(
        Heading(2, "Questionnaire scores"),
        Para(
            "Scores by the instruments' published scoring (pedvr.study.scoring): per block, each score "
            "by condition with a one-way repeated-measures ANOVA (Greenhouse–Geisser corrected where "
            "Mauchly's "
            "test rejects sphericity), Bonferroni post hoc tests with Hedges' g and a Friedman test. "
            + CI_METHOD
        ),
    )
    for qid, blocks in qs["by_block"].items():
        for block, b in blocks.items():
            named = [(SCORE_LABELS.get(k, k), v) for k, v in b["scores"].items()]
            doc.add(
                Heading(3, f"{qid} ({_scoring_title(qs, qid)}), {block}"),
                _levels_table("score", b["levels"], named, 2),
                Bullets(tuple(_tests_line(n, r) for n, r in named)),
            )
            doc.figure(
                f"scores_{_slug(qid)}_{_slug(block)}.svg",
                f"{qid} scores by condition in {block}",
                partial(_fig_levels, f"{qid}, {block}", [(n, b["levels"], r) for n, r in named]),
            )
    if qs["once"]:
        rows = []
        for qid, scores in qs["once"].items():
            for k, d in scores.items():
                rows.append(
                    (
                        qid,
                        SCORE_LABELS.get(k, k),
                        str(d["n"]),
                        _fmt(d["mean"]),
                        _fmt(d["sd"]),
                        f"{_fmt(d['min'])}–{_fmt(d['max'])}",
                    )
                )
        doc.add(
            Heading(3, "Questionnaires given once (not per condition)"),
            Table(
                ("questionnaire", "score", "n", "M", "SD", "range"),
                tuple(rows),
                (False, False, True, True, True, True),
            ),
        )


def _measures(doc: _Doc, result: dict[str, Any]) -> None:
    m = result.get("measures")
    if not m or not m["by_block"]:
        return
    doc.add(
        Heading(2, "Objective measures"),
        Para(
            "Per trial from the recorded samples (definitions in pedvr.study.measures), over the trials that "
            "ran to their end; compared across conditions (across responsibility in a sweep) with the same "
            "tests as the questionnaire scores. " + CI_METHOD
        ),
    )
    for block, b in m["by_block"].items():
        named = [(f"{m['labels'][k]} ({m['units'][k]})", v) for k, v in b["measures"].items()]
        if not named:
            continue
        by = "responsibility" if b["design"] == "sweep" else "condition"
        doc.add(
            Heading(3, f"{block} ({b['scenario']}, by {by})"),
            _levels_table("measure", b["levels"], named, 3),
            Bullets(tuple(_tests_line(n, r) for n, r in named)),
        )
        doc.figure(
            f"measures_{_slug(block)}.svg",
            f"objective measures in {block}",
            partial(_fig_levels, block, [(n, b["levels"], r) for n, r in named]),
        )


def _ssq(doc: _Doc, result: dict[str, Any]) -> None:
    ssq = result.get("ssq")
    if not ssq or not ssq["summary"]:
        return
    rows = []
    for phase in ("before", "after", "change"):
        if phase in ssq["summary"]:
            row = ssq["summary"][phase]
            rows.append(
                (
                    f"{phase} (n = {row['total']['n']})",
                    *(f"{row[k]['mean']:.2f} (SD {_fmt(row[k]['sd'])})" for k in SSQ_SCORES),
                )
            )
    doc.add(
        Heading(2, "Simulator sickness (SSQ, Kennedy et al. 1993)"),
        Table(
            ("", "Nausea", "Oculomotor", "Disorientation", "Total"),
            tuple(rows),
            (False, True, True, True, True),
        ),
    )
    tests = ssq.get("tests") or {}
    if tests:
        trows = []
        for k in SSQ_SCORES:
            t = tests[k]
            trows.append(
                (
                    k,
                    str(t["n"]),
                    _fmt(t["mean_change"]),
                    apa_paired_t(t["t"]) if t["t"] else "–",
                    apa_wilcoxon(t["wilcoxon"]) if t["wilcoxon"] else "–",
                )
            )
        doc.add(
            Heading(3, "Change from before to after"),
            Table(
                ("score", "n", "mean change", "paired t (d_z)", "Wilcoxon signed-rank (rank-biserial r)"),
                tuple(trows),
                (False, True, True, False, False),
            ),
            Para(
                "Paired over the participants with both administrations complete. SSQ scores are usually "
                "skewed: "
                "the Wilcoxon signed-rank test is the safer reading; d_z = mean change / SD of the changes."
            ),
        )


def _corridor(doc: _Doc, result: dict[str, Any]) -> None:
    cor = result.get("corridor")
    if not cor or not cor["trials"]:
        return
    rows = []
    for rho, b in cor["by_responsibility"].items():
        g = b["gave_way"]
        rows.append(
            (
                rho,
                str(b["n"]),
                f"{b['min_distance_m']['mean']:.3f}",
                f"{b['user_lateral_deviation_m']['mean']:.3f}",
                f"{b['agent_lateral_deviation_m']['mean']:.3f}",
                f"{b['contacts']} ({b['trials_with_contact']} trials)",
                f"{g['user']} / {g['agent']} / {g['both']} / {g['neither']}",
            )
        )
    doc.add(
        Heading(2, "Head-on corridor by responsibility"),
        Table(
            (
                "responsibility",
                "trials",
                "min distance (m)",
                "user lateral dev. (m)",
                "agent lateral dev. (m)",
                "contacts",
                "gave way: user / agent / both / neither",
            ),
            tuple(rows),
            (True, True, True, True, True, True, False),
        ),
        Para(
            "Means over trials. Minimum distance is between disc centres (two radii, 0.5 m, is touching). "
            "Lateral deviation is the largest distance from the walker's initial line of travel (set by its "
            "first "
            "metre); a walker gave way when it deviated at least 0.1 m and at least twice as much as the "
            "other. "
            "Contacts are episodes of overlapping discs between the participant and the agent."
        ),
    )
    doc.figure("corridor_trajectories.svg", "corridor trajectories", partial(_fig_corridor, cor))


def _response_times(doc: _Doc, result: dict[str, Any]) -> None:
    rt = result.get("response_times")
    simulated = (result.get("sample") or {}).get("simulated", 0)
    if not rt:
        if simulated:
            doc.add(
                Heading(2, "Response times"),
                Para(
                    f"None to report: the answers come from {simulated} simulated participant"
                    f"{'s' if simulated != 1 else ''} (a dry run), who answer as soon as they are asked."
                ),
            )
        return
    rows = tuple(
        (q, str(v["n"]), _fmt(v["median_s"]), f"{_fmt(v['q1_s'])}–{_fmt(v['q3_s'])}") for q, v in rt.items()
    )
    whose = "participants'" if simulated != 1 else "participant's"
    left_out = (
        f" The {simulated} simulated {whose} answers are left out (they take no time)." if simulated else ""
    )
    doc.add(
        Heading(2, "Response times"),
        Para(
            "Seconds from the item shown to the answer confirmed, over all answers to each questionnaire."
            + left_out
        ),
        Table(
            ("questionnaire", "answers", "median (s)", "interquartile range (s)"),
            rows,
            (False, True, True, True),
        ),
    )


# -- rendering ------------------------------------------------------------------------------------


def _md_cell(s: str) -> str:
    return s.replace("|", "\\|").replace("\n", " ")


def to_markdown(blocks: list[Block]) -> str:
    out: list[str] = []
    for b in blocks:
        if isinstance(b, Heading):
            out += ["#" * b.level + " " + b.text, ""]
        elif isinstance(b, Para):
            out += [b.text, ""]
        elif isinstance(b, Bullets):
            out += [f"- {i}" for i in b.items] + [""]
        elif isinstance(b, Table):
            right = b.right or (False,) * len(b.header)
            out.append("| " + " | ".join(_md_cell(h) for h in b.header) + " |")
            out.append("|" + "|".join("---:" if r else "---" for r in right) + "|")
            out += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
            out.append("")
        else:
            out += [f"![{b.alt}]({b.file})", ""]
    return "\n".join(out) + "\n"


CSS = """
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; max-width: 70em; margin: 2em auto;
       padding: 0 1em;
       color: #222; line-height: 1.45; }
h1, h2, h3 { font-weight: 600; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; margin: .8em 0; font-size: .92em; }
th, td { border-bottom: 1px solid #ddd; padding: .25em .6em; vertical-align: top; }
th { border-bottom: 2px solid #888; text-align: left; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 1em 0; } figure svg { max-width: 100%; height: auto; }
figcaption { font-size: .85em; color: #555; }
"""


def _inline_svg(path: Path) -> str:
    text = path.read_text(encoding="utf-8")
    start = text.find("<svg")
    return text[start:] if start >= 0 else text


def to_html(blocks: list[Block], *, title: str, folder: Path) -> str:
    e = html.escape
    out = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{e(title)}</title>",
        f"<style>{CSS}</style></head><body>",
    ]
    for b in blocks:
        if isinstance(b, Heading):
            out.append(f"<h{b.level}>{e(b.text)}</h{b.level}>")
        elif isinstance(b, Para):
            out.append(f"<p>{e(b.text)}</p>")
        elif isinstance(b, Bullets):
            out.append("<ul>" + "".join(f"<li>{e(i)}</li>" for i in b.items) + "</ul>")
        elif isinstance(b, Table):
            right = b.right or (False,) * len(b.header)
            cls = [' class="num"' if r else "" for r in right]
            out.append(
                "<table><thead><tr>"
                + "".join(f"<th{c}>{e(h)}</th>" for h, c in zip(b.header, cls, strict=True))
            )
            out.append("</tr></thead><tbody>")
            for row in b.rows:
                out.append(
                    "<tr>" + "".join(f"<td{c}>{e(x)}</td>" for x, c in zip(row, cls, strict=True)) + "</tr>"
                )
            out.append("</tbody></table>")
        else:
            out.append(
                f'<figure id="fig-{e(Path(b.file).stem)}">{_inline_svg(folder / b.file)}'
                f"<figcaption>{e(b.alt)} ({e(b.file)})</figcaption></figure>"
            )
    out.append("</body></html>")
    return "\n".join(out) + "\n"


def write_report(result: dict[str, Any], *, out: str | Path) -> Path:
    """Write ``report.html``, ``report.md`` and their SVG figures into ``out``; return the HTML path.

    Raises :class:`~pedvr.study.errors.OutputError` (one line) when ``out``
    cannot be made a writable folder or a file cannot be written.
    """
    out = Path(out)
    prepare_folder(out, what="report")
    doc = _Doc(out=out)
    src = result.get("source", {})
    title = "Study analysis"
    doc.add(
        Heading(1, title),
        Para(
            f"Source: {src.get('database') or src.get('responses')}. Participants: "
            f"{result['n_participants']}; "
            f"pairwise responses: {result['n_responses']}. Pairwise responses are recoded so that 1 means "
            "the "
            "left condition of each comparison is much better and 4 means no difference (PedVR §6.2.4); the "
            "social-presence index is each participant's mean over the items (PedVR §6.5)."
        ),
    )
    sample = result.get("sample") or {}
    if sample.get("participants") and sample.get("simulated") == sample.get("participants"):
        doc.add(
            Para(
                f"A dry run: all {sample['participants']} participants are simulated (scripted walks, seeded "
                "answers, no response times). The numbers test the protocol and the pipeline, not people."
            )
        )
    _sample(doc, result)
    _pairwise(doc, result)
    _questionnaires(doc, result)
    _measures(doc, result)
    _ssq(doc, result)
    _corridor(doc, result)
    _response_times(doc, result)
    md_text = to_markdown(doc.blocks)
    html_text = to_html(doc.blocks, title=title, folder=out)
    write_file(out / "report.md", lambda p: p.write_text(md_text, encoding="utf-8"))
    write_file(out / "report.html", lambda p: p.write_text(html_text, encoding="utf-8"))
    return out / "report.html"
