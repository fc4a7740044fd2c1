"""Plots of the measures (matplotlib's Agg backend: files, no window), runs side by side.

* ``*_setup.png``: each run's trajectories in the walkable area with the measurement area
  and line (PedPy's :func:`pedpy.plot_measurement_setup`), one panel per run;
* ``*_nt.png``: N(t), the cumulative crossings of the line, with each run's steady state;
* ``*_density_speed.png``: Voronoi density and speed in the area over time;
* ``*_fd.png``: the fundamental diagram, per-frame (density, speed) pairs in the steady
  state, with Weidmann's curve.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pedvr.measure.measures import Measures, Setup
from pedvr.measure.references import weidmann_speed

if TYPE_CHECKING:
    from pedvr.measure.cases import Case
    from pedvr.measure.trajectories import Run

COLORS = {
    "real": "black",
    "pedvr": "tab:red",
    "decoupled": "tab:orange",
    "jupedsim-cfsm": "tab:blue",
    "jupedsim-avm": "tab:green",
    "jupedsim-sfm": "tab:purple",
    "jupedsim-gcfm": "tab:brown",
}


def _plt():  # noqa: ANN202
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _color(label: str, k: int) -> str:
    return COLORS.get(label, f"C{k % 10}")


def plot_runs(
    runs: Mapping[str, tuple[Run, Measures]], setups: Mapping[str, Setup], *, folder: Path, name: str
) -> list[Path]:
    """Every plot of the module docstring for ``runs`` (label -> run and its measures), each
    measured in ``setups[label]``; returns the files written (PNG) under ``folder``."""
    import pedpy

    plt = _plt()
    folder.mkdir(parents=True, exist_ok=True)
    out: list[Path] = []
    labels = list(runs)

    fig, axes = plt.subplots(1, len(labels), figsize=(4.5 * len(labels), 5), squeeze=False)
    for ax, label in zip(axes[0], labels, strict=True):
        run, _ = runs[label]
        s = setups[label]
        areas = [pedpy.MeasurementArea(s.area)] if s.area is not None else []
        lines = [pedpy.MeasurementLine(list(s.line))] if s.line is not None else []
        pedpy.plot_measurement_setup(
            traj=run.traj,
            walkable_area=s.pedpy_walkable(),
            measurement_areas=areas,
            measurement_lines=lines,
            axes=ax,
            traj_width=0.2,
            traj_alpha=0.4,
            ma_alpha=0.2,
            ma_color="g",
            ml_color="b",
            ml_width=2,
        )
        ax.set_aspect("equal")
        ax.set_title(label)
    fig.tight_layout()
    out.append(_save(fig, folder / f"{name}_setup.png"))

    if any(m.nt for _, m in runs.values()):
        fig, ax = plt.subplots(figsize=(7, 5))
        for k, label in enumerate(labels):
            m = runs[label][1]
            if not m.nt:
                continue
            c = _color(label, k)
            ax.plot(
                m.nt["t"],
                m.nt["n"],
                color=c,
                label=f"{label}: {m.crossed} crossed"
                + (f", J = {m.flow:.2f}/s" if m.flow is not None else ""),
            )
            if m.steady_s is not None:
                ax.axvspan(*m.steady_s, color=c, alpha=0.08)
        ax.set_xlabel("t / s")
        ax.set_ylabel("N(t): crossed the line")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"{name}: crossings (shaded: steady state)")
        out.append(_save(fig, folder / f"{name}_nt.png"))

    if any(m.series for _, m in runs.values()):
        fig, (a0, a1) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
        for k, label in enumerate(labels):
            m = runs[label][1]
            if not m.series:
                continue
            c = _color(label, k)
            a0.plot(m.series["t"], m.series["density"], color=c, lw=1, label=label)
            a1.plot(m.series["t"], m.series["speed"], color=c, lw=1, label=label)
        a0.set_ylabel("Voronoi density / m⁻²")
        a1.set_ylabel("Voronoi speed / m s⁻¹")
        a1.set_xlabel("t / s")
        for a in (a0, a1):
            a.grid(alpha=0.3)
        a0.legend(fontsize=8)
        a0.set_title(f"{name}: in the measurement area")
        out.append(_save(fig, folder / f"{name}_density_speed.png"))

        fig, ax = plt.subplots(figsize=(7, 5))
        rho = np.linspace(0.05, 5.4, 200)
        ax.plot(rho, weidmann_speed(rho), color="grey", ls="--", label="Weidmann 1993")
        for k, label in enumerate(labels):
            m = runs[label][1]
            if not m.series:
                continue
            t = m.series["t"]
            sel = (
                np.ones(t.size, np.bool_)
                if m.steady_s is None
                else (t >= m.steady_s[0]) & (t <= m.steady_s[1])
            )
            slope = "" if m.slope is None else f", dv/dρ = {m.slope:+.2f}"
            ax.scatter(
                m.series["density"][sel],
                m.series["speed"][sel],
                s=4,
                alpha=0.4,
                color=_color(label, k),
                label=f"{label}{slope}",
            )
        ax.set_xlim(0, 5.5)
        ax.set_ylim(0, 2.0)
        ax.set_xlabel("Voronoi density ρ / m⁻²")
        ax.set_ylabel("Voronoi speed v / m s⁻¹")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"{name}: fundamental diagram (steady state)")
        out.append(_save(fig, folder / f"{name}_fd.png"))
    return out


def plot_case(case: Case, runs: Mapping[str, tuple[Run, Measures]], *, folder: Path) -> list[Path]:
    """:func:`plot_runs` for a validation case: the real run in its own walkable area, the
    models in the scene's."""
    from pedvr.measure.measures import walkable_polygon
    from pedvr.scene.loader import load_any

    scene_walk = walkable_polygon(load_any(case.scene_path(), seed=None).world)
    setups = {}
    for label in runs:
        walk = case.real.walkable if label == "real" and case.real is not None else scene_walk
        setups[label] = Setup(walkable=walk, area=case.area, line=case.line)
    return plot_runs(runs, setups, folder=folder, name=case.name)


def _save(fig: object, path: Path) -> Path:
    fig.savefig(path, dpi=90)  # type: ignore[attr-defined]
    _plt().close(fig)  # type: ignore[arg-type]
    return path
