"""The analysis report: Markdown with PNG figures (matplotlib, Agg backend).

``report.md`` has, per scenario, the response frequencies laid out as PedVR
Table 3, Cronbach's α, the repeated-measures ANOVA with Mauchly's test and
the Greenhouse–Geisser correction, Bonferroni post hoc tests, one-sample
tests against 4 and the Friedman test, written in APA style; histograms of
the responses like PedVR Fig. 6; SSQ scores; and the head-on corridor
trajectories and measures by responsibility.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pedvr.study.analysis import MIDPOINT, SCALE_MAX, SCALE_MIN, apa_friedman, apa_p, apa_rm_anova, apa_t

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


def _name(c: str) -> str:
    return NAMES.get(c, c)


def _cmp_name(c: str) -> str:
    left, right = c.split("/")
    return f"{_name(left)} / {_name(right)}"


def _fig_histograms(scen: str, comps: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(comps), figsize=(4.2 * len(comps), 3.6), sharey=True, squeeze=False)
    for ax, (c, s) in zip(axes[0], comps.items(), strict=True):
        n = max(s["n_responses"], 1)
        pct = [100.0 * s["frequencies"][str(v)] / n for v in range(SCALE_MIN, SCALE_MAX + 1)]
        colors = [
            "#3b6fb6" if v < MIDPOINT else "#999999" if v == MIDPOINT else "#c8553d"
            for v in range(SCALE_MIN, SCALE_MAX + 1)
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
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fig_corridor(corridor: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    rhos = sorted({t["responsibility"] for t in corridor["trajectories"]})
    fig, axes = plt.subplots(len(rhos), 1, figsize=(8, 1.9 * len(rhos)), sharex=True, squeeze=False)
    for ax, rho in zip(axes[:, 0], rhos, strict=True):
        for t in corridor["trajectories"]:
            if t["responsibility"] != rho:
                continue
            u, a = t["user"], t["agent"]
            ax.plot([p[0] for p in u], [p[1] for p in u], color="#3b6fb6", lw=1, alpha=0.8)
            ax.plot([p[0] for p in a], [p[1] for p in a], color="#c8553d", lw=1, alpha=0.8)
        ax.set_title(f"responsibility {rho:g} (blue: user, red: agent)", fontsize=9)
        ax.set_ylabel("y (m)")
        ax.set_aspect("equal", adjustable="datalim")
    axes[-1, 0].set_xlabel("x (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fmt(v: Any, d: int = 2) -> str:
    return "–" if v is None else f"{v:.{d}f}"


def write_report(result: dict[str, Any], *, out: str | Path) -> Path:
    """Write ``report.md`` and its PNG figures into ``out``; return the Markdown path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    src = result.get("source", {})
    lines = [
        "# Study analysis",
        "",
        f"Source: {src.get('database') or src.get('responses')}. Participants: {result['n_participants']}; "
        f"pairwise responses: {result['n_responses']}. Responses are recoded so that 1 means the *left* "
        "condition of each comparison is much better and 4 means no difference (PedVR §6.2.4). "
        "The social-presence index is each participant's mean over the items (PedVR §6.5).",
        "",
    ]
    for scen, s in result["scenarios"].items():
        per = s["comparisons"]
        lines += [
            f"## {scen}",
            "",
            "### Responses (cf. PedVR Table 3)",
            "",
            "| Left | Right | "
            + " | ".join(str(v) for v in range(SCALE_MIN, SCALE_MAX + 1))
            + " | n | mean | SD | % < 4 | % = 1 | % = 4 | α |",
            "|---|---|" + "---:|" * (SCALE_MAX - SCALE_MIN + 1) + "---:|---:|---:|---:|---:|---:|---:|",
        ]
        for v in per.values():
            freq = " | ".join(str(v["frequencies"][str(k)]) for k in range(SCALE_MIN, SCALE_MAX + 1))
            lines.append(
                f"| {_name(v['left'])} | {_name(v['right'])} | {freq} | {v['n']} | {_fmt(v['mean'])} | "
                f"± {_fmt(v['sd'])} | {_fmt(v['pct_less_than_4'], 1)} | {_fmt(v['pct_equal_1'], 1)} | "
                f"{_fmt(v['pct_equal_4'], 1)} | {_fmt(v['cronbach_alpha'])} |"
            )
        png = f"histograms_{scen}.png"
        _fig_histograms(scen, per, out / png)
        lines += ["", f"![{scen} histograms]({png})", "", "### Statistics", ""]
        alphas = [v["cronbach_alpha"] for v in per.values() if v["cronbach_alpha"] is not None]
        if alphas:
            each = ", ".join(
                f"{_cmp_name(c)}: α = {v['cronbach_alpha']:.2f}"
                for c, v in per.items()
                if v["cronbach_alpha"] is not None
            )
            lines.append(
                f"- Reliability of the index: Cronbach's α from {min(alphas):.2f} to {max(alphas):.2f} "
                f"({each})."
            )
        a = s.get("rm_anova")
        if a:
            lines.append(
                f"- One-way repeated-measures ANOVA of the index over the comparisons "
                f"(n = {s['n']}): {apa_rm_anova(a)}."
            )
            for ph in s["posthoc_bonferroni"] or []:
                lines.append(
                    f"  - Post hoc (paired, Bonferroni) {_cmp_name(ph['a'])} vs {_cmp_name(ph['b'])}: "
                    f"t({ph['dof']:g}) = {ph['t']:.2f}, {apa_p(ph['p_bonferroni'])}, "
                    f"Hedges' g = {ph['hedges_g']:.2f}."
                )
        else:
            lines.append(f"- No ANOVA: {s.get('note', 'not enough data')}.")
        if s.get("friedman"):
            lines.append(f"- Friedman test: {apa_friedman(s['friedman'])}.")
        for c, v in per.items():
            t = v["one_sample_t_vs_4"]
            if t:
                lines.append(
                    f"- {_cmp_name(c)}: M = {v['mean']:.2f}, SD = {_fmt(v['sd'])}; against 4 "
                    f"{apa_t(t)} (Bonferroni over comparisons: {apa_p(t['p_bonferroni'])}), "
                    f"d = {t['cohen_d']:.2f}."
                )
        if s.get("excluded"):
            lines.append(f"- Left out of the ANOVA (missing a comparison): {', '.join(s['excluded'])}.")
        lines.append("")
    ssq = result.get("ssq")
    if ssq and ssq["summary"]:
        lines += [
            "## Simulator sickness (SSQ, Kennedy et al. 1993)",
            "",
            "| | Nausea | Oculomotor | Disorientation | Total |",
            "|---|---:|---:|---:|---:|",
        ]
        for phase in ("before", "after", "change"):
            if phase in ssq["summary"]:
                row = ssq["summary"][phase]
                cells = " | ".join(
                    f"{row[k]['mean']:.2f} (SD {_fmt(row[k]['sd'])})"
                    for k in ("nausea", "oculomotor", "disorientation", "total")
                )
                lines.append(f"| {phase} (n = {row['total']['n']}) | {cells} |")
        lines.append("")
    cor = result.get("corridor")
    if cor and cor["trials"]:
        lines += [
            "## Head-on corridor by responsibility",
            "",
            "| responsibility | trials | min distance (m) | user lateral dev. (m) | agent lateral dev. (m) | "
            "gave way: user / agent / both / neither |",
            "|---:|---:|---:|---:|---:|---|",
        ]
        for rho, b in cor["by_responsibility"].items():
            g = b["gave_way"]
            lines.append(
                f"| {rho} | {b['n']} | {b['min_distance_m']['mean']:.2f} | "
                f"{b['user_lateral_deviation_m']['mean']:.2f} | {b['agent_lateral_deviation_m']['mean']:.2f} "
                f"| {g['user']} / {g['agent']} / {g['both']} / {g['neither']} |"
            )
        _fig_corridor(cor, out / "corridor_trajectories.png")
        lines += [
            "",
            "Minimum distance is between disc centres. Lateral deviation is the largest distance from "
            "the walker's initial line of travel (set by its first metre); a walker gave way when it "
            "deviated at least 0.1 m and at least twice as much as the other.",
            "",
            "![corridor trajectories](corridor_trajectories.png)",
            "",
        ]
    md = out / "report.md"
    md.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return md
