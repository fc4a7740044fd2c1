"""pedvr.measure on trajectories whose density, speed and flow are known analytically, on the
published relations, and on a small pedvr run; real data where the user has it."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
import shapely

from pedvr.measure import MeasureError, Setup, from_arrays, from_simulation, measure, steady_window
from pedvr.measure.measures import fd_slope, flow_from_crossings
from pedvr.measure.references import bottleneck_flow, weidmann_specific_flow, weidmann_speed

CORRIDOR = shapely.box(0.0, 0.0, 20.0, 2.0)


def lattice(*, lanes: int = 2, spacing: float = 1.0, speed: float = 1.0, seconds: float = 40.0,
            dt: float = 1.0 / 90.0, user: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """People in ``lanes`` evenly spread lanes across the 2 m corridor, ``spacing`` m apart along
    it, lanes staggered by ``spacing / lanes``, all walking +x at ``speed``; each is present
    (not NaN) only while inside the corridor. Every Voronoi cell then has the area
    ``2 * spacing / lanes``: density ``lanes / (2 spacing)``, flow ``lanes speed / spacing``."""
    t = np.arange(0.0, seconds + 1e-9, dt)
    width = 2.0
    per_lane = int(math.ceil((20.0 + speed * seconds) / spacing)) + 1
    xs, ys = [], []
    for k in range(lanes):
        y = (k + 0.5) * width / lanes
        for j in range(per_lane):
            xs.append(20.0 - j * spacing - k * spacing / lanes)  # at t = 0, the corridor is full
            ys.append(y)
    x0, y0 = np.asarray(xs), np.asarray(ys)
    x = x0[None, :] + speed * t[:, None]
    pos = np.stack([x, np.broadcast_to(y0, x.shape)], axis=-1)
    pos[(x <= 0.0) | (x >= 20.0)] = np.nan
    ids = np.arange(x0.size)
    is_user = np.zeros(x0.size, np.bool_)
    if user:  # a standing person in the measurement area, who must not be measured
        pos = np.concatenate([pos, np.broadcast_to([10.0, 1.0], (t.size, 1, 2))], axis=1)
        ids = np.append(ids, x0.size)
        is_user = np.append(is_user, True)
    return t, pos, ids, is_user


def test_uniform_lattice_gives_its_analytic_density_speed_and_flow() -> None:
    t, pos, ids, is_user = lattice(lanes=2, spacing=1.0, speed=1.0, user=True)
    run = from_arrays(t, pos, ids=ids, is_user=is_user, fps=10.0, label="lattice")
    assert run.traj.frame_rate == pytest.approx(10.0)
    assert int(run.traj.data["id"].max()) < ids[-1]  # the user is left out
    m = measure(run, Setup(walkable=CORRIDOR, area=shapely.box(8.0, 0.0, 12.0, 2.0), line=((10.0, 0.0), (10.0, 2.0))))
    assert m.density == pytest.approx(1.0, rel=1e-3)  # 2 lanes / (2 m x 1 m)
    assert m.speed == pytest.approx(1.0, rel=1e-3)
    assert m.flow == pytest.approx(2.0, rel=1e-2)  # lanes * speed / spacing
    assert m.time_gap_median == pytest.approx(0.5, abs=0.051)  # one crossing every 0.5 s (frames of 0.1 s)
    assert m.specific_flow == pytest.approx(1.0, rel=1e-2)  # J / width = rho v


def test_denser_slower_lattices_give_a_negative_slope() -> None:
    rho, v = [], []
    for lanes, speed in ((1, 1.3), (2, 1.0), (3, 0.7)):
        t, pos, ids, _ = lattice(lanes=lanes, spacing=1.0, speed=speed, seconds=20.0)
        m = measure(from_arrays(t, pos, ids=ids, fps=8.0), Setup(walkable=CORRIDOR, area=shapely.box(8, 0, 12, 2)))
        rho.append(m.series["density"])
        v.append(m.series["speed"])
        assert m.density == pytest.approx(lanes / 2.0, rel=1e-3)
    # density 0.5, 1.0, 1.5 /m² at 1.3, 1.0, 0.7 m/s: dv/drho = -0.6
    assert fd_slope(np.concatenate(rho), np.concatenate(v)) == pytest.approx(-0.6, rel=1e-3)


def test_steady_window_trims_the_first_and_last_tenth_of_the_crossings() -> None:
    times = np.arange(100.0)
    assert steady_window(times) == (10.0, 89.0)
    assert flow_from_crossings(times, (10.0, 89.0)) == pytest.approx(1.0)
    assert steady_window(np.asarray([1.0, 2.0])) is None  # too few crossings: no steady state


def test_nobody_crossing_gives_none_not_a_number() -> None:
    t, pos, ids, _ = lattice(seconds=5.0)
    m = measure(from_arrays(t, pos, ids=ids, fps=10.0),
                Setup(walkable=CORRIDOR, area=shapely.box(8, 0, 12, 2), line=((30.0, 0.0), (30.0, 2.0))))
    assert m.crossed == 0 and m.flow is None and m.density is None and m.speed is None


def test_measure_needs_an_area_or_a_line() -> None:
    t, pos, ids, _ = lattice(seconds=2.0)
    with pytest.raises(MeasureError, match="nothing to measure: give a measurement area or a line"):
        measure(from_arrays(t, pos, ids=ids), Setup(walkable=CORRIDOR))


def test_a_recording_without_motion_is_refused() -> None:
    with pytest.raises(MeasureError, match=r"a recording of 1 step\(s\) has no motion to measure"):
        from_arrays(np.zeros(1), np.zeros((1, 1, 2)), ids=np.zeros(1, np.int64))


def test_weidmann_and_the_bottleneck_line() -> None:
    assert weidmann_speed(1e-6) == pytest.approx(1.34, rel=1e-3)
    assert weidmann_speed(5.4) == 0.0 and weidmann_speed(6.0) == 0.0
    assert weidmann_speed(1.0) == pytest.approx(1.34 * (1 - math.exp(-1.913 * (1 - 1 / 5.4))))
    rho = np.linspace(0.1, 5.3, 521)
    js = weidmann_specific_flow(rho)
    assert 1.7 <= rho[np.argmax(js)] <= 2.0 and 1.2 <= js.max() <= 1.3  # crowd-data.md: peak near 1.8-2 /m²
    assert np.all(np.diff(weidmann_speed(rho)) < 0)  # slower when denser
    assert bottleneck_flow(1.0) == pytest.approx(1.9) and bottleneck_flow(0.5) == pytest.approx(1.15)
    assert bottleneck_flow(0.8 - 1e-9) == pytest.approx(bottleneck_flow(0.8))


def test_a_pedvr_run_with_a_source_is_measured_at_its_metered_rate() -> None:
    """A source of 1.2 agents/s on a free corridor: the flow at a line is the source's rate."""
    from pedvr.scene.loader import parse_scene
    from pedvr.sim import Simulation

    data = {
        "scene": {"name": "metered", "seed": 2, "duration": 30.0},
        "world": {"bounds": [[-10.0, -1.5], [10.0, 1.5]]},
        "agents": {"profiles": {"p": {"radius": 0.25, "pref_speed": 1.3, "max_speed": 1.6}},
                   "sources": [{"profile": "p", "state": "walk", "rate": 1.2, "line": [[-9.0, -1.0], [-9.0, 1.0]],
                                "max_count": 24}],
                   "sinks": [{"region": {"box": [8.5, -1.5, 10.0, 1.5]}}]},
        "behavior": {"states": {"walk": {"goal": {"selector": "region", "box": [9.0, -1.0, 9.8, 1.0]}}}},
        "user": {"start": [0.0, 0.0], "enabled": False},
    }
    sim = Simulation(parse_scene(data, source="metered.toml"), record=True)
    sim.advance_to(30.0)
    run = from_simulation(sim)
    m = measure(run, Setup(walkable=shapely.box(-10, -1.5, 10, 1.5), area=shapely.box(-1, -1.5, 1, 1.5),
                           line=((0.0, -1.5), (0.0, 1.5))))
    assert run.agents == 24 and m.crossed == 24
    assert m.flow == pytest.approx(1.2, rel=0.1)
    assert m.speed == pytest.approx(1.3, rel=0.1)  # free walking
    assert m.density == pytest.approx(1.2 / (1.3 * 3.0), rel=0.35)  # J = rho v w


REAL = os.environ.get("PEDVR_REAL_DATA")


def _real(rel: str) -> Path:
    if not REAL or not (Path(REAL) / rel).is_file():
        pytest.skip(f"real data: set PEDVR_REAL_DATA to PedPy's notebooks/demo-data (needs {rel})")
    return Path(REAL) / rel


def test_real_corridor_070_reproduces_the_issue_figures() -> None:
    from pedvr.measure.cases import get_case
    from pedvr.measure.trajectories import load_real

    case = get_case("uo_070")
    assert case.real is not None
    run = load_real(_real(case.real.file), unit="cm", fps=16.0)
    m = measure(run, Setup(walkable=case.real.walkable, area=case.area, line=case.line))
    assert run.agents == 111 and m.crossed == 111
    assert m.flow == pytest.approx(1.60, abs=0.01) and m.speed == pytest.approx(1.34, abs=0.01)


def test_real_bottleneck_050_reproduces_the_issue_figures() -> None:
    from pedvr.measure.cases import get_case
    from pedvr.measure.trajectories import load_real

    case = get_case("bottleneck_050")
    assert case.real is not None
    run = load_real(_real(case.real.file), unit="m")
    m = measure(run, Setup(walkable=case.real.walkable, line=case.line))
    assert run.traj.frame_rate == 25.0  # from the file's header
    assert m.crossed == 75 and m.flow == pytest.approx(1.16, abs=0.01)
