"""The field's measures through PedPy: in a measurement area and at a measurement line.

What is computed (Zhang et al. 2011's method D and the flow at a line, as in
PedPy's ``fundamental_diagram.ipynb`` and ``user_guide.ipynb``):

* **N(t) and crossings** at the line: :func:`pedpy.compute_n_t` (each person's first
  crossing, either way).
* **Steady state from the crossing times** (:func:`steady_window`): the crossings
  from the ``STEADY_TRIM``-th share to the ``1 - STEADY_TRIM``-th share, i.e. the
  first and last 10 % of the people who pass are the start-up (the front arrives,
  the queue builds) and the emptying (the tail passes). pedvr's choice: PedPy
  leaves the steady state to the analyst (its corridor notebook lists one per run
  by hand), and a rule applied the same way to a real run and a simulated one is
  what makes the two comparable.
* **Flow** in the steady state: ``(n - 1) / (t_n - t_1)`` over its ``n`` crossings
  (persons/s; the Δt method: the time between the first and the last crossing
  holds ``n - 1`` gaps). **Time gaps**: the differences of consecutive crossing
  times, their median and mean.
* **Voronoi density and speed** in the measurement area, per frame:
  :func:`pedpy.compute_individual_voronoi_polygons` (cells cut to the walkable
  area), :func:`pedpy.compute_voronoi_density`, individual speeds over
  ``±SPEED_WINDOW_S`` (:func:`pedpy.compute_individual_speed`, single sided at the
  ends) weighted by the cells' shares, :func:`pedpy.compute_voronoi_speed`. Their
  means over the steady state's frames are the figures reported; the per-frame
  pairs are the fundamental diagram.
* **Speed against density**: the least-squares slope ``dv/dρ`` of those pairs
  (m³/s per person: negative where people slow down in denser crowds).

Measures that cannot be computed (nobody crossed; the area stayed empty) are
``None``, never a made-up number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from pedvr.measure.errors import MeasureError

if TYPE_CHECKING:
    import pandas as pd
    import pedpy

    from pedvr.measure.trajectories import Run

STEADY_TRIM = 0.1  # share of the crossings at each end left out of the steady state
SPEED_WINDOW_S = 0.3125  # s each side of a frame for individual speeds (5 frames at 16 fps, PedPy's notebook)
MIN_STEADY_CROSSINGS = 3  # fewer crossings in the window: no steady flow


@dataclass(frozen=True)
class Setup:
    """Where to measure: the walkable area (polygon, m), the measurement area (polygon) and the
    measurement line (two points; optional)."""

    walkable: shapely.Polygon
    area: shapely.Polygon | None = None
    line: tuple[tuple[float, float], tuple[float, float]] | None = None
    cutoff: float | None = None  # m: Voronoi cells cut to discs of this radius (None: no cut-off)

    def pedpy_walkable(self) -> pedpy.WalkableArea:
        import pedpy

        try:
            return pedpy.WalkableArea(self.walkable)
        except pedpy.PedPyError as exc:
            raise MeasureError(f"walkable area: PedPy rejects it ({exc})") from None


def walkable_polygon(world: Any) -> shapely.Polygon:
    """The scene world's walkable area (:func:`pedvr.world.walkable_area`) as one polygon; where it
    falls apart into pieces (an island no one can reach), the largest piece."""
    from pedvr.world import walkable_area

    area = walkable_area(world)
    if isinstance(area, shapely.MultiPolygon):
        area = max(area.geoms, key=lambda g: g.area)
    if area.is_empty:
        raise MeasureError("walkable area: the scene has none (obstacles cover everything)")
    return area


@dataclass
class Measures:
    """One run's measures (SI units; None where they cannot be computed)."""

    label: str
    agents: int
    frame_rate: float
    crossed: int | None = None  # people who crossed the line
    flow: float | None = None  # persons/s in the steady state
    steady_s: tuple[float, float] | None = None  # s: the steady state (first, last crossing in it)
    time_gap_median: float | None = None  # s
    time_gap_mean: float | None = None  # s
    density: float | None = None  # persons/m², Voronoi, mean over the steady state
    speed: float | None = None  # m/s, Voronoi, mean over the steady state
    specific_flow: float | None = None  # persons/(m s): density * speed
    slope: float | None = None  # dv/dρ of the per-frame pairs in the steady state
    first_crossing_s: float | None = None
    last_crossing_s: float | None = None
    # per-frame series for plots: time s, density, speed (steady state or not)
    series: dict[str, np.ndarray] = field(default_factory=dict)
    nt: dict[str, np.ndarray] = field(default_factory=dict)  # time s, cumulative crossings

    def summary(self) -> dict[str, Any]:
        def r(v: float | None, d: int = 4) -> float | None:
            return None if v is None or not math.isfinite(v) else round(float(v), d)

        return {
            "label": self.label,
            "agents": self.agents,
            "frame_rate": r(self.frame_rate, 3),
            "crossed": self.crossed,
            "flow_per_s": r(self.flow),
            "steady_s": None if self.steady_s is None else [r(self.steady_s[0], 3), r(self.steady_s[1], 3)],
            "time_gap_median_s": r(self.time_gap_median),
            "time_gap_mean_s": r(self.time_gap_mean),
            "density_per_m2": r(self.density),
            "speed_mps": r(self.speed),
            "specific_flow_per_ms": r(self.specific_flow),
            "slope_dv_drho": r(self.slope),
            "first_crossing_s": r(self.first_crossing_s, 3),
            "last_crossing_s": r(self.last_crossing_s, 3),
        }


def steady_window(times: np.ndarray, *, trim: float = STEADY_TRIM) -> tuple[float, float] | None:
    """The steady state from sorted crossing times (s): from the crossing at share ``trim`` to the
    one at share ``1 - trim`` (see the module docstring); None with fewer than
    ``MIN_STEADY_CROSSINGS`` crossings in it."""
    t = np.sort(np.asarray(times, np.float64))
    n = t.size
    lo, hi = int(math.floor(trim * n)), int(math.ceil((1.0 - trim) * n)) - 1
    if hi - lo + 1 < MIN_STEADY_CROSSINGS:
        return None
    return float(t[lo]), float(t[hi])


def flow_from_crossings(times: np.ndarray, window: tuple[float, float]) -> float | None:
    """Persons/s from crossing times inside ``window``: ``(n - 1) / (t_n - t_1)``."""
    t = np.sort(np.asarray(times, np.float64))
    t = t[(t >= window[0] - 1e-9) & (t <= window[1] + 1e-9)]
    if t.size < MIN_STEADY_CROSSINGS or t[-1] <= t[0]:
        return None
    return float((t.size - 1) / (t[-1] - t[0]))


def crossing_times(
    run: Run, line: tuple[tuple[float, float], tuple[float, float]]
) -> tuple[np.ndarray, pd.DataFrame]:
    """Each person's first crossing of ``line`` (s, sorted) and PedPy's N(t) table."""
    import pedpy

    ml = pedpy.MeasurementLine(list(line))
    nt, crossing = pedpy.compute_n_t(traj_data=run.traj, measurement_line=ml)
    times = np.sort(crossing["frame"].to_numpy(np.float64)) / run.traj.frame_rate
    return times, nt


def voronoi_series(run: Run, setup: Setup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per frame: time (s), Voronoi density (persons/m²) and Voronoi speed (m/s) in the area."""
    import pedpy

    assert setup.area is not None
    ma = pedpy.MeasurementArea(setup.area)
    wa = setup.pedpy_walkable()
    traj = run.traj
    cut = None if setup.cutoff is None else pedpy.Cutoff(radius=setup.cutoff, quad_segments=3)
    try:
        cells = pedpy.compute_individual_voronoi_polygons(traj_data=traj, walkable_area=wa, cut_off=cut)
    except pedpy.PedPyError as exc:
        raise MeasureError(
            f"{run.label}: PedPy's Voronoi cells failed ({exc}); are the trajectories "
            "inside the walkable area?"
        ) from None
    density, intersecting = pedpy.compute_voronoi_density(individual_voronoi_data=cells, measurement_area=ma)
    step = max(1, round(SPEED_WINDOW_S * traj.frame_rate))
    speed_i = pedpy.compute_individual_speed(
        traj_data=traj, frame_step=step, speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED
    )
    speed = pedpy.compute_voronoi_speed(
        traj_data=traj,
        individual_speed=speed_i,
        individual_voronoi_intersection=intersecting,
        measurement_area=ma,
    )
    both = density.merge(speed, on="frame", how="inner")
    t = both["frame"].to_numpy(np.float64) / traj.frame_rate
    return t, both["density"].to_numpy(np.float64), both["speed"].to_numpy(np.float64)


def measure(run: Run, setup: Setup, *, steady: tuple[float, float] | None = None) -> Measures:
    """Every measure the setup allows (line: crossings, flow, gaps; area: density, speed, the
    fundamental diagram). ``steady`` (s) overrides the steady state drawn from the crossings;
    without a line and without ``steady`` the whole run is averaged."""
    if setup.area is None and setup.line is None:
        raise MeasureError(f"{run.label}: nothing to measure: give a measurement area or a line")
    m = Measures(label=run.label, agents=run.agents, frame_rate=float(run.traj.frame_rate))
    window = steady
    if setup.line is not None:
        times, nt = crossing_times(run, setup.line)
        m.crossed = int(times.size)
        m.nt = {
            "t": nt["frame"].to_numpy(np.float64) / run.traj.frame_rate,
            "n": nt["cumulative_pedestrians"].to_numpy(np.float64),
        }
        if times.size:
            m.first_crossing_s, m.last_crossing_s = float(times[0]), float(times[-1])
        if window is None:
            window = steady_window(times)
        if window is not None:
            m.steady_s = window
            m.flow = flow_from_crossings(times, window)
            inside = times[(times >= window[0] - 1e-9) & (times <= window[1] + 1e-9)]
            gaps = np.diff(inside)
            if gaps.size:
                m.time_gap_median, m.time_gap_mean = float(np.median(gaps)), float(gaps.mean())
    elif window is not None:
        m.steady_s = window
    if setup.area is not None:
        t, rho, v = voronoi_series(run, setup)
        m.series = {"t": t, "density": rho, "speed": v}
        sel = np.ones(t.size, np.bool_) if window is None else (t >= window[0]) & (t <= window[1])
        if setup.line is not None and window is None:
            sel[:] = False  # nobody crossed: there is no steady state to average
        ok = sel & np.isfinite(rho) & np.isfinite(v)
        if ok.any():
            m.density, m.speed = float(rho[ok].mean()), float(v[ok].mean())
            m.specific_flow = m.density * m.speed
            m.slope = fd_slope(rho[ok], v[ok])
    return m


def fd_slope(density: np.ndarray, speed: np.ndarray) -> float | None:
    """Least-squares slope dv/dρ of speed against density; None when density does not vary."""
    rho, v = np.asarray(density, np.float64), np.asarray(speed, np.float64)
    ok = np.isfinite(rho) & np.isfinite(v)
    rho, v = rho[ok], v[ok]
    if rho.size < 3 or float(np.ptp(rho)) < 1e-6:
        return None
    return float(np.polyfit(rho, v, 1)[0])
