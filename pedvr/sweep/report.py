"""``pedvr sweep report DIR``: plots of each metric against each swept parameter, and a Markdown page.

For every numeric metric that varies across the sweep's ``ok`` rows and every
swept parameter (and ``scene`` when there are several), one PNG
(``DIR/report/plots/<metric>__<parameter>.png``) shows the mean over the
other parameters and the seeds at each value with its 95 % confidence
interval, ``mean ± t(0.975, n−1)·sd/√n`` (Student's t; no interval where
n = 1); with several scenes, one line per scene. ``DIR/report/report.md`` has
the counts, the failed runs, the same means and intervals as tables,
SteerBench scores per scene when the rows have them, and the figures.

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


def write_sweep_report(folder: str | Path, *, out: str | Path | None = None) -> Path:
    """Write the report of the sweep in ``folder``; return the Markdown file's path."""
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
        lines += _runs_section(manifest, ok, out)
    md = out / "report.md"
    md.write_text("\n".join(lines) + "\n")
    return md


def _metrics(ok: pd.DataFrame, parameters: list[str]) -> tuple[list[str], dict[str, Any]]:
    """Numeric, non-bool metric columns that vary; and those that are the same in every row."""
    varying, constant = [], {}
    for c in ok.columns:
        if (
            c in IDENTITY
            or c in parameters
            or ok[c].dtype == bool
            or not pd.api.types.is_numeric_dtype(ok[c])
        ):
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


def _runs_section(manifest: dict[str, Any], ok: pd.DataFrame, out: Path) -> list[str]:
    parameters = [p for p in manifest.get("parameters", []) if p in ok.columns]
    swept = [p for p in manifest.get("swept", []) if p in ok.columns]
    scenes = sorted(ok["scene"].unique()) if len(ok) else []
    axes = swept + (["scene"] if len(scenes) > 1 else [])
    metrics, constant = _metrics(ok, parameters)
    lines = [
        f"Swept: {', '.join(swept) or 'nothing (seeds only)'}; scenes: {', '.join(scenes)}; "
        f"seeds per combination: {ok.groupby(['scene', *swept]).size().min() if len(ok) else 0}.",
        "",
    ]
    if constant:
        lines += [
            "Metrics with one value in every run: "
            + ", ".join(f"`{k}` = {_fmt(float(v))}" for k, v in sorted(constant.items()))
            + ".",
            "",
        ]
    bench = [m for m in metrics + list(constant) if m.startswith("steerbench.")]
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
    for axis in axes:
        lines += _axis_section(ok, axis, metrics, scenes if axis != "scene" else [], out)
    return lines


def _axis_section(ok: pd.DataFrame, axis: str, metrics: list[str], scenes: list[str], out: Path) -> list[str]:
    values = sorted(ok[axis].dropna().unique(), key=lambda v: (isinstance(v, str), v))
    numeric = all(isinstance(v, int | float | np.integer | np.floating) for v in values)
    groups = [(s, ok[ok["scene"] == s]) for s in scenes] if len(scenes) > 1 else [("", ok)]
    lines = [
        f"## Against `{axis}`",
        "",
        "| metric | " + " | ".join(f"{axis} = {v}" for v in values) + " |",
        "|---|" + "---:|" * len(values),
    ]
    figures = []
    for metric in metrics:
        stats = {}
        for label, sub in groups:
            stats[label] = [
                confidence_interval(sub.loc[sub[axis] == v, metric].to_numpy(dtype=float)) for v in values
            ]
            cells = [_fmt(m) + ("" if not math.isfinite(h) else f" ± {_fmt(h)}") for m, h, _ in stats[label]]
            lines.append(f"| `{metric}`{f' ({label})' if label else ''} | " + " | ".join(cells) + " |")
        path = out / "plots" / f"{_safe(metric)}__{_safe(axis)}.png"
        _plot(path, metric=metric, axis=axis, values=values, numeric=numeric, stats=stats)
        figures.append(f"![{metric} against {axis}](plots/{path.name})")
    return lines + [""] + figures + [""]


def _plot(
    path: Path,
    *,
    metric: str,
    axis: str,
    values: list[Any],
    numeric: bool,
    stats: dict[str, list[tuple[float, float, int]]],
) -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.0, 3.4), dpi=100, layout="constrained")
    ax = fig.add_subplot()
    x = np.asarray(values, dtype=float) if numeric else np.arange(len(values), dtype=float)
    for k, (label, st) in enumerate(stats.items()):
        mean = np.asarray([m for m, _, _ in st])
        half = np.nan_to_num(np.asarray([h for _, h, _ in st]), nan=0.0)
        shift = 0.0 if numeric else (k - (len(stats) - 1) / 2) * 0.08
        ax.errorbar(
            x + shift,
            mean,
            yerr=half,
            marker="o",
            capsize=3,
            label=label or None,
            linestyle="-" if numeric else "none",
        )
    if not numeric:
        ax.set_xticks(x, [str(v) for v in values])
    ax.set_xlabel(axis)
    ax.set_ylabel(metric)
    ax.set_title(f"{metric}: mean and 95 % CI", fontsize=9)
    if len(stats) > 1:
        ax.legend(fontsize=7)
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
