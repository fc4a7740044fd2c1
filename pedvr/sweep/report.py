"""``pedvr sweep report DIR``: the measures that matter against each swept parameter, and a page.

For a runs sweep, the *factors* are the swept parameters (and ``scene`` when
there are several). For each factor ``x`` one figure
(``DIR/report/plots/by_<x>.png``) has a row of panels per measure: each panel
shows, at each value of ``x``, the mean over seeds with its 95 % confidence
interval, ``mean ± t(0.975, n−1)·sd/√n`` (Student's t; no bar where n = 1),
one line per value of the next factor (the *series*) and one column of panels
per value of the factor after that (the *facets*), so interactions show as
lines that are not parallel. Further factors, if any, are averaged over, and
the figure and the page say which (issue 25.10: every plot used to average
over every other parameter, and plotted wall times and the parameters
themselves).

The *measures* are :data:`MEASURES` (the user's clearance, overlaps, speed
and arrivals, motion limits, doors) and SteerBench scores, those that vary
across the ``ok`` rows, in that order; ``pedvr sweep report DIR --metric NAME``
(repeatable) picks others. Timing columns (machine, not simulation) and the
parameters themselves are never measures by default. ``DIR/report/report.md``
has the counts, the code that made the rows (:mod:`pedvr.provenance`),
the failed runs, per factor the figure and a table of the same means and
intervals, SteerBench scores per scene when the rows have them, and lists the
metrics not plotted; ``DIR/report/summary.csv`` has every mean and interval
of every figure, one row per cell.

For a simulated-participants sweep the page lists every participant, counts
the trial orders counterbalancing produced (a dry-run check that each order
occurs as often as designed), and runs the study's own analysis and report
(:func:`pedvr.study.analysis.analyze`, :func:`pedvr.study.report.write_report`)
on the sweep's merged store into ``DIR/report/study/``.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pedvr.sweep.errors import SweepError
from pedvr.sweep.runner import MANIFEST
from pedvr.sweep.table import TABLE_NAME, read_table

# Run columns that are not metrics (identity, bookkeeping).
IDENTITY = (
    "run_key",
    "scene",
    "scene_source",
    "seed",
    "duration",
    "pedvr_version",
    "status",
    "error",
    "recording",
    "scene_hash",
    "participant",
    "number",
    "protocol",
    "max_trial_seconds",
    "order",
)


def confidence_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float, int]:
    """(mean, half-width of the ``level`` interval by Student's t, n); half-width NaN for n < 2."""
    from scipy.stats import t as student_t

    v = values[np.isfinite(values)]
    n = int(v.size)
    if n == 0:
        return math.nan, math.nan, 0
    mean = float(v.mean())
    if n < 2:
        return mean, math.nan, n
    half = float(student_t.ppf(0.5 + level / 2, n - 1) * v.std(ddof=1) / math.sqrt(n))
    return mean, half, n


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.+-]+", "_", name)


def _fmt(x: float) -> str:
    if x is None or not math.isfinite(x):
        return "–"
    return f"{x:.4g}"


def write_sweep_report(
    folder: str | Path, *, out: str | Path | None = None, metrics: list[str] | None = None
) -> Path:
    """Write the report of the sweep in ``folder``; return the Markdown file's path.

    ``metrics``: the measures to plot (default: :data:`MEASURES` and SteerBench scores that vary);
    a name that is not a numeric column of the table is a :class:`SweepError`."""
    folder = Path(folder)
    if not (folder / TABLE_NAME).is_file():
        raise SweepError(f"{folder}: no {TABLE_NAME} here; give the --out folder of a sweep")
    manifest = json.loads((folder / MANIFEST).read_text()) if (folder / MANIFEST).is_file() else {}
    df = read_table(folder).to_pandas()
    out = Path(out) if out is not None else folder / "report"
    (out / "plots").mkdir(parents=True, exist_ok=True)
    ok = df[df["status"] == "ok"]
    versions = ", ".join(sorted(df["pedvr_version"].dropna().unique()))
    lines = [
        f"# Sweep {manifest.get('name', folder.name)}",
        "",
        f"Spec: `{manifest.get('spec', '?')}`; pedvr {versions}. "
        f"Rows: {len(df)} of {manifest.get('tasks', '?')} planned; {len(ok)} ok, "
        f"{int((df['status'] == 'error').sum())} failed, {int((df['status'] == 'lost').sum())} lost.",
        "",
    ]
    lines += _code_section(df)
    bad = df[df["status"] != "ok"]
    if len(bad):
        lines += ["## Failed runs", "", "| run | status | error |", "|---|---|---|"]
        for _, r in bad.head(50).iterrows():
            who = (
                r.get("participant")
                if "participant" in df.columns
                else f"{r.get('scene')} seed {r.get('seed')}"
            )
            lines.append(f"| {who} | {r['status']} | {str(r['error']).replace('|', '/')} |")
        lines.append("")
    if manifest.get("kind") == "participants":
        lines += _participants_section(folder, manifest, df, out)
    else:
        lines += _runs_section(manifest, ok, out, chosen=metrics)
    md = out / "report.md"
    md.write_text("\n".join(lines) + "\n")
    return md


# The outcome measures plotted by default, in this order, where they vary: the user's clearance,
# the crowd's overlaps, flow, the body's motion limits, doors. SteerBench scores follow them.
MEASURES = (
    "min_user_distance_m",
    "user_clearance_p5_m",
    "user_clearance_p50_m",
    "steps_in_user_margin",
    "user_overlap_max_m",
    "max_overlap_m",
    "overlaps_over_1cm",
    "wall_overlap_max_m",
    "mean_speed_mps",
    "arrivals",
    "stalled_agents",
    "max_accel_mps2",
    "max_turn_rate_radps",
    "foot_skate_p95_m",
    "door_passages",
    "door_holds_for_user",
    "door_wait_s_p95",
)


def _code_section(df: pd.DataFrame) -> list[str]:
    """The code that made the rows (issue 25.8): one line per distinct code, with its row count."""
    from pedvr.provenance import COLUMNS, describe

    if not set(COLUMNS) <= set(df.columns):
        return ["Code: the rows do not record it (made before pedvr 0.2.0).", ""]
    made = df[df["status"] == "ok"]
    groups = made[list(COLUMNS)].astype(object).where(made[list(COLUMNS)].notna(), None)
    counts = groups.value_counts(dropna=False)
    if len(counts) <= 1:
        only = dict(zip(COLUMNS, counts.index[0], strict=True)) if len(counts) else None
        return [f"Code: {describe(only)}." if only else "Code: no ok rows.", ""]
    lines = [f"**Code: the ok rows were made by {len(counts)} different codes** (`--allow-mixed-code`):", ""]
    lines += [
        f"- {n} row{'s' if n != 1 else ''}: {describe(dict(zip(COLUMNS, k, strict=True)))}"
        for k, n in counts.items()
    ]
    return lines + [""]


def _numeric(ok: pd.DataFrame, c: str) -> bool:
    return ok[c].dtype != bool and pd.api.types.is_numeric_dtype(ok[c])


def _metrics(ok: pd.DataFrame, parameters: list[str]) -> tuple[list[str], dict[str, Any]]:
    """Numeric, non-bool metric columns that vary; and those that are the same in every row."""
    from pedvr.provenance import COLUMNS

    varying, constant = [], {}
    for c in ok.columns:
        if c in IDENTITY or c in parameters or c in COLUMNS or not _numeric(ok, c):
            continue
        v = ok[c].to_numpy(dtype=float)
        fin = v[np.isfinite(v)]
        if fin.size == 0:
            continue
        if np.all(fin == fin[0]):
            constant[c] = fin[0]
        else:
            varying.append(c)
    from pedvr.sweep.task import is_timing

    return sorted(varying, key=is_timing), constant  # the simulation's metrics first, the machine's last


def _measures(ok: pd.DataFrame, varying: list[str], chosen: list[str] | None, folder: Path) -> list[str]:
    if chosen:
        bad = [m for m in chosen if m not in ok.columns or not _numeric(ok, m)]
        if bad:
            numeric = sorted(c for c in ok.columns if _numeric(ok, c) and c not in IDENTITY)
            raise SweepError(
                f"--metric {bad[0]}: not a numeric column of {folder / TABLE_NAME}; "
                f"numeric columns: {', '.join(numeric)}"
            )
        return list(dict.fromkeys(chosen))
    bench = sorted(m for m in varying if m.startswith("steerbench."))
    return [m for m in MEASURES if m in varying] + bench


def _ordered(values: Any) -> list[Any]:
    """Distinct values, numbers ascending then text; None (the scene's own value) first."""
    vals = list(dict.fromkeys(None if _missing(v) else v for v in values))
    return sorted(vals, key=lambda v: (v is not None, isinstance(v, str), v if v is not None else 0))


def _missing(v: Any) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def _label(v: Any) -> str:
    return "default" if v is None else str(v)


def _select(df: pd.DataFrame, col: str, v: Any) -> pd.DataFrame:
    return df[df[col].isna()] if v is None else df[df[col] == v]


def _runs_section(
    manifest: dict[str, Any], ok: pd.DataFrame, out: Path, *, chosen: list[str] | None = None
) -> list[str]:
    parameters = [p for p in manifest.get("parameters", []) if p in ok.columns]
    swept = [p for p in manifest.get("swept", []) if p in ok.columns]
    scenes = sorted(ok["scene"].unique()) if len(ok) else []
    factors = swept + (["scene"] if len(scenes) > 1 else [])
    varying, constant = _metrics(ok, parameters)
    measures = _measures(ok, varying, chosen, out.parent)
    per_combo = ok.groupby(["scene", *swept], dropna=False).size().min() if len(ok) else 0
    lines = [
        f"Swept: {', '.join(swept) or 'nothing (seeds only)'}; scenes: {', '.join(scenes)}; "
        f"seeds per combination: {per_combo}.",
        "",
    ]
    if constant:
        lines += [
            "Metrics with one value in every run: "
            + ", ".join(f"`{k}` = {_fmt(float(v))}" for k, v in sorted(constant.items()))
            + ".",
            "",
        ]
    bench = [m for m in varying + list(constant) if m.startswith("steerbench.")]
    if bench and len(ok):
        lines += [
            "## SteerBench scores per scene",
            "",
            "Means over seeds and parameters, ± 95 % CI (lower is better; `pedvr.sweep.steerbench` has "
            "the definitions).",
            "",
            "| scene | " + " | ".join(b.removeprefix("steerbench.") for b in sorted(bench)) + " |",
            "|---|" + "---:|" * len(bench),
        ]
        for s in scenes:
            sub = ok[ok["scene"] == s]
            cells = []
            for b in sorted(bench):
                m, h, _ = confidence_interval(sub[b].to_numpy(dtype=float))
                cells.append(_fmt(m) + ("" if not math.isfinite(h) else f" ± {_fmt(h)}"))
            lines.append(f"| {s} | " + " | ".join(cells) + " |")
        lines.append("")
    summary: list[dict[str, Any]] = []
    if measures and len(ok):
        for x in factors or ["scene"]:
            lines += _factor_section(ok, x, [f for f in factors if f != x], measures, out, summary)
    rest = [m for m in varying if m not in measures]
    if rest:
        lines += [
            "Varying metrics not plotted (`pedvr sweep report DIR --metric NAME` plots them): "
            + ", ".join(f"`{m}`" for m in rest)
            + ".",
            "",
        ]
    if summary:
        pd.DataFrame(summary).to_csv(out / "summary.csv", index=False)
        lines += ["Every mean and interval above: [summary.csv](summary.csv).", ""]
    else:
        (out / "summary.csv").unlink(missing_ok=True)  # a stale one from an earlier report
    return lines


def _factor_section(
    ok: pd.DataFrame, x: str, others: list[str], measures: list[str], out: Path, cells: list[dict[str, Any]]
) -> list[str]:
    """One factor on the x axis: the first other factor as series, the second as facets, the rest
    averaged over; a figure with a row per measure, and a table."""
    series, facet = (others + [None, None])[:2]
    averaged = others[2:]
    xs = _ordered(ok[x])
    ss = _ordered(ok[series]) if series else [None]
    fs = _ordered(ok[facet]) if facet else [None]
    # stats[measure][(facet value, series value)] = [(mean, half, n) per x value]
    stats: dict[str, dict[tuple[Any, Any], list[tuple[float, float, int]]]] = {}
    for m in measures:
        stats[m] = {}
        for fv in fs:
            sub_f = _select(ok, facet, fv) if facet else ok
            for sv in ss:
                sub = _select(sub_f, series, sv) if series else sub_f
                row = []
                for xv in xs:
                    ci = confidence_interval(_select(sub, x, xv)[m].to_numpy(dtype=float))
                    row.append(ci)
                    cell = {
                        "x": x,
                        "x_value": _label(xv),
                        "measure": m,
                        "mean": ci[0],
                        "ci95": ci[1],
                        "n": ci[2],
                    }
                    if series:
                        cell.update(series=series, series_value=_label(sv))
                    if facet:
                        cell.update(facet=facet, facet_value=_label(fv))
                    cells.append(cell)
                stats[m][(fv, sv)] = row
    path = out / "plots" / f"by_{_safe(x)}.png"
    _plot(path, x=x, xs=xs, series=series, ss=ss, facet=facet, fs=fs, averaged=averaged, stats=stats)
    how = []
    if series:
        how.append(f"one line per `{series}`")
    if facet:
        how.append(f"one column of panels per `{facet}`")
    if averaged:
        how.append(f"averaged over {', '.join(f'`{a}`' for a in averaged)}")
    lines = [
        f"## Against `{x}`",
        "",
        "Mean over seeds and 95 % CI" + (f"; {'; '.join(how)}" if how else "") + ".",
        "",
        f"![measures against {x}](plots/{path.name})",
        "",
        "| measure | "
        + " | ".join(h for h in (series, facet) if h)
        + (" | " if series or facet else "")
        + " | ".join(f"{x} = {_label(v)}" for v in xs)
        + " |",
        "|---|" + "---|" * (bool(series) + bool(facet)) + "---:|" * len(xs),
    ]
    for m in measures:
        for (fv, sv), row in stats[m].items():
            if all(n == 0 for _, _, n in row):
                continue
            keys = [_label(v) for v, h in ((sv, series), (fv, facet)) if h]
            vals = [_fmt(mean) + ("" if not math.isfinite(h) else f" ± {_fmt(h)}") for mean, h, _ in row]
            lines.append(f"| `{m}` | " + "".join(f"{k} | " for k in keys) + " | ".join(vals) + " |")
    return lines + [""]


def _plot(
    path: Path,
    *,
    x: str,
    xs: list[Any],
    series: str | None,
    ss: list[Any],
    facet: str | None,
    fs: list[Any],
    averaged: list[str],
    stats: dict[str, dict[tuple[Any, Any], list[tuple[float, float, int]]]],
) -> None:
    from matplotlib.figure import Figure

    numeric = all(
        isinstance(v, int | float | np.integer | np.floating) and not isinstance(v, bool) for v in xs
    )
    xpos = np.asarray(xs, dtype=float) if numeric else np.arange(len(xs), dtype=float)
    span = float(np.ptp(xpos)) if len(xpos) > 1 else 1.0
    rows, cols = len(stats), len(fs)
    panel_w = max(3.1, (0.1 if numeric else 0.4) * len(xs))  # many scenes need room for their names
    fig = Figure(figsize=(1.2 + panel_w * cols, 0.9 + 1.9 * rows), dpi=100, layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey="row")
    colours = [f"C{k % 10}" for k in range(len(ss))]
    for r, (measure, by) in enumerate(stats.items()):
        for c, fv in enumerate(fs):
            ax = axes[r][c]
            for k, sv in enumerate(ss):
                st = by[(fv, sv)]
                mean = np.asarray([m for m, _, _ in st])
                half = np.nan_to_num(np.asarray([h for _, h, _ in st]), nan=0.0)
                shift = (k - (len(ss) - 1) / 2) * (0.015 * span if numeric else 0.06)
                ax.errorbar(
                    xpos + shift,
                    mean,
                    yerr=half,
                    marker="o",
                    markersize=3.5,
                    capsize=2.5,
                    color=colours[k],
                    label=f"{series} = {_label(sv)}" if series else None,
                    linestyle="-" if numeric else ":",
                    linewidth=1.2,
                )
            ax.grid(True, linewidth=0.4, alpha=0.5)
            ax.tick_params(labelsize=7)
            if r == 0 and facet:
                ax.set_title(f"{facet} = {_label(fv)}", fontsize=8)
            if c == 0:
                ax.set_ylabel(measure, fontsize=7)
            if r == rows - 1:
                ax.set_xlabel(x, fontsize=8)
                if not numeric or len(xs) <= 8:  # tick the swept values themselves
                    turn = 35 if len(xs) > 4 else 0
                    ax.set_xticks(
                        xpos, [_label(v) for v in xs], rotation=turn, ha="right" if turn else "center"
                    )
                if not numeric:
                    ax.set_xlim(-0.5, len(xs) - 0.5)
    title = f"against {x}: mean over seeds, 95 % CI"
    if averaged:
        title += f"; averaged over {', '.join(averaged)}"
    fig.suptitle(title, fontsize=9)
    if series:
        handles, labels = axes[0][0].get_legend_handles_labels()
        fig.legend(
            handles, labels, loc="outside lower center", ncols=min(len(ss), 5), fontsize=7, frameon=False
        )
    fig.savefig(path)


def _participants_section(folder: Path, manifest: dict[str, Any], df: pd.DataFrame, out: Path) -> list[str]:
    lines = [
        "## Simulated participants",
        "",
        "| participant | status | steps | trials | answers |",
        "|---|---|---:|---:|---:|",
    ]
    for _, r in df.sort_values("number").iterrows():
        lines.append(
            f"| {r['participant']} | {r.get('participant_status') or r['status']} | "
            f"{_int(r.get('steps_done'))}/{_int(r.get('steps_total'))} | {_int(r.get('trials'))} | "
            f"{_int(r.get('answers'))} |"
        )
    lines.append("")
    if "order" in df.columns:
        counts = df.loc[df["status"] == "ok", "order"].value_counts()
        lines += [
            "## Trial orders (counterbalancing)",
            "",
            f"{len(counts)} distinct orders over {int(counts.sum())} participants.",
            "",
            "| participants | order |",
            "|---:|---|",
        ]
        lines += [f"| {n} | {o.replace('>', ' → ')} |" for o, n in counts.items()]
        lines.append("")
    store = folder / f"{manifest.get('study')}.sqlite"
    if store.is_file():
        from pedvr.errors import PedvrError
        from pedvr.study.analysis import analyze
        from pedvr.study.report import write_report

        try:
            md = write_report(analyze(db=store), out=out / "study")
            lines += [
                "## Study analysis",
                "",
                f"The study's analysis of the merged store `{store.name}`: "
                f"[{md.relative_to(out)}]({md.relative_to(out)}).",
                "",
            ]
        except PedvrError as exc:
            lines += ["## Study analysis", "", f"The study's analysis did not run: {exc}", ""]
    return lines


def _int(v: Any) -> str:
    try:
        return str(int(v))
    except (TypeError, ValueError):
        return "–"
