"""``pedvr bench realism``: the validation scenes run by each model, measured like the field does,
against the real recordings and the published relations (issue 26).

For each case (:mod:`pedvr.measure.cases`) and model it runs the scene headless,
measures the run with PedPy (:mod:`pedvr.measure.measures`) in the case's
measurement area and at its line, and reports each measure beside its
references with the relative error ``(model - reference) / reference``. Models:

* ``pedvr`` (the coupled model, the default condition) and ``decoupled`` (plain
  ORCA; :class:`pedvr.sim.Simulation`'s conditions);
* ``jupedsim-cfsm``, ``jupedsim-avm``, ``jupedsim-sfm``, ``jupedsim-gcfm``: JuPedSim's
  collision-free speed, anticipation velocity, social force and generalized
  centrifugal force models, where ``jupedsim`` is installed (the bench extra), in the
  same walkable area with the same start positions, the same sources (through
  :class:`pedvr.inflow.Inflow`, so arrivals wait for a free spot as pedvr's do), the
  same radius and desired speed; a JuPedSim agent leaves at the sink its goal lies
  in (an exit stage). JuPedSim has no doors: a door is an open doorway there.
* ``real``: the real recording, when the data folder has it.

References, per measure: ``real`` (the same measure on the real recording) and
``published`` (Weidmann's speed at the run's own density in corridors, Seyfried
et al.'s flow-width line at bottlenecks, everyone through at doors). Pooled over
the corridor cases: the slope dv/dρ of speed against density per model.

This is a benchmark, not a test: a whole run takes minutes (``--cases`` and
``--duration`` choose less).
"""

from __future__ import annotations

import functools
import math
import os
import time
import traceback
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import shapely

from pedvr.measure import references as ref
from pedvr.measure.cases import CASES, DEFAULT_CASES, Case, data_dir, get_case, real_file
from pedvr.measure.errors import MeasureError
from pedvr.measure.measures import Measures, Setup, fd_slope, measure, walkable_polygon
from pedvr.measure.trajectories import DEFAULT_FPS, Run, from_arrays, from_simulation, load_real

PEDVR_MODELS = ("pedvr", "decoupled")
JUPEDSIM_MODELS = ("jupedsim-cfsm", "jupedsim-avm", "jupedsim-sfm", "jupedsim-gcfm")
MODELS = PEDVR_MODELS + JUPEDSIM_MODELS
DEFAULT_MODELS = ("pedvr", "decoupled", "jupedsim-cfsm")
REPORTED = ("passed_share", "flow_per_s", "density_per_m2", "speed_mps", "time_gap_median_s")


def have_jupedsim() -> bool:
    try:
        import jupedsim  # noqa: F401
    except ImportError:
        return False
    return True


def rel_error(value: float | None, reference: float | None) -> float | None:
    """``(value - reference) / reference``; None when either is missing or the reference is 0."""
    if value is None or reference is None or reference == 0 or not math.isfinite(value):
        return None
    return round((value - reference) / reference, 4)


def _measures_dict(m: Measures, passed_of: int) -> dict[str, Any]:
    out = m.summary()
    out["passed_share"] = None if m.crossed is None or passed_of == 0 else round(m.crossed / passed_of, 4)
    out["passed_of"] = passed_of
    return out


def _expected_agents(case: Case, sim_agents: int) -> int:
    """Everyone the scene brings in: its spawns plus each source's max_count (the share that
    passed is of these, also when a source could not place them all in time)."""
    from pedvr.scene.loader import load_any

    scene = load_any(case.scene_path(), seed=None)
    n = sum(len(s.positions) or s.count for s in scene.spawns)
    n += sum(s.max_count for s in scene.sources)
    return max(n, sim_agents)


def run_pedvr(
    case: Case, *, condition: str, duration: float, seed: int | None, fps: float = DEFAULT_FPS
) -> tuple[Run, dict[str, Any]]:
    """Run the case's scene with pedvr's model ``condition``; the run and its summary."""
    from pedvr.scene.loader import load_any
    from pedvr.sim import Simulation

    scene = load_any(case.scene_path(), seed=seed)
    sim = Simulation(scene, seed=seed, condition=condition, record=True)
    t0 = time.perf_counter()
    sim.advance_to(duration)
    wall = time.perf_counter() - t0
    s = sim.summary()
    keep = (
        "overlaps_over_1cm",
        "max_overlap_m",
        "stalled_agents",
        "stalled_agents_ever",
        "arrivals",
        "source_agents_added",
        "source_agents_waiting",
        "source_max_wait_s",
        "sink_agents_removed",
        "door_openings",
        "door_deadlocks",
        "mean_speed_mps",
        "step_ms_p50",
    )
    info = {k: s[k] for k in keep if k in s}
    info["wall_s"] = round(wall, 2)
    return from_simulation(sim, fps=fps, label=f"{case.name} {condition}"), info


def run_jupedsim(
    case: Case,
    *,
    model: str,
    duration: float,
    seed: int | None,
    fps: float = DEFAULT_FPS,
    dt: float = 0.01,
    radius: float | None = None,
) -> tuple[Run, dict[str, Any]]:
    """Run the case with a JuPedSim model in the scene's walkable area: the same start positions
    (pedvr's, drawn with the seed), the same sources (arrivals wait for a free spot), the same
    radius and desired speed; agents leave at the sink their goal lies in."""
    import jupedsim as jps

    from pedvr.inflow import Inflow
    from pedvr.scene.loader import load_any
    from pedvr.sim import Simulation

    scene = load_any(case.scene_path(), seed=seed)
    start = Simulation(scene, seed=seed, condition="decoupled")  # start positions as pedvr draws them
    walkable = walkable_polygon(scene.world)
    kinds = {
        "jupedsim-cfsm": (jps.CollisionFreeSpeedModel, jps.CollisionFreeSpeedModelAgentParameters),
        "jupedsim-avm": (jps.AnticipationVelocityModel, jps.AnticipationVelocityModelAgentParameters),
        "jupedsim-sfm": (jps.SocialForceModel, jps.SocialForceModelAgentParameters),
        "jupedsim-gcfm": (
            jps.GeneralizedCentrifugalForceModel,
            jps.GeneralizedCentrifugalForceModelAgentParameters,
        ),
    }
    model_cls, params_cls = kinds[model]
    sim = jps.Simulation(model=model_cls(), geometry=walkable, dt=dt)
    journeys: dict[str, tuple[int, int]] = {}
    for name, st in scene.behavior.states.items():
        if st.goal is None or st.goal.kind != "region":
            raise MeasureError(f"case {case.name}: state {name!r} has no region goal; JuPedSim needs an exit")
        goal = shapely.box(*st.goal.params["box"])  # type: ignore[misc]
        exit_poly = next(
            (
                shapely.box(*s.region[1])
                for s in scene.sinks
                if s.region[0] == "box" and shapely.box(*s.region[1]).intersects(goal)
            ),
            goal,
        )
        exit_poly = exit_poly.intersection(walkable)
        stage = sim.add_exit_stage(list(exit_poly.exterior.coords)[:-1])
        journeys[name] = (sim.add_journey(jps.JourneyDescription([stage])), stage)

    prof_of = {k: scene.profiles[sp.profile] for k, sp in enumerate(scene.spawns)}

    def params(pos: tuple[float, float], state: str, profile: Any) -> Any:
        journey, stage = journeys[state]
        kw: dict[str, Any] = {
            "position": pos,
            "journey_id": journey,
            "stage_id": stage,
            "radius": profile.radius if radius is None else radius,
            "desired_speed": profile.pref_speed,
        }
        if model == "jupedsim-gcfm":  # GCFM's agents are ellipses; it names its speed v0
            kw = {
                "position": pos,
                "journey_id": journey,
                "stage_id": stage,
                "desired_speed": profile.pref_speed,
            }
        return params_cls(**kw)

    virt = ~start.crowd.is_user
    rows = np.flatnonzero(virt)
    state_of = [start.bfsm.names[int(start.behavior.state[r])] for r in rows]
    spawn_rows = [k for k, sp in enumerate(scene.spawns) for _ in range(len(sp.positions) or sp.count)]
    ids: dict[int, int] = {}  # jupedsim id -> pedvr-style stable id (arrival order)
    for r, state, k in zip(rows, state_of, spawn_rows, strict=False):
        jid = sim.add_agent(
            params((float(start.crowd.pos[r, 0]), float(start.crowd.pos[r, 1])), state, prof_of[k])
        )
        ids[jid] = len(ids)
    inflow = Inflow(scene.sources, ())
    shrunk: dict[float, Any] = {}

    def inside(p: tuple[float, float], r: float) -> bool:
        """On the walkable area shrunk by the radius (pedvr's navmesh test, for JuPedSim)."""
        if r not in shrunk:
            shrunk[r] = walkable.buffer(-r)
            shapely.prepare(shrunk[r])
        return bool(shrunk[r].contains(shapely.Point(p)))

    rng = np.random.default_rng(start.seed)
    every = max(1, round((1.0 / dt) / fps))
    frames: list[tuple[float, dict[int, tuple[float, float]]]] = []
    t0 = time.perf_counter()
    steps = math.ceil(duration / dt - 1e-9)
    for i in range(steps + 1):
        t = i * dt
        for k, src in enumerate(inflow.sources):
            owed = inflow.owed(k, t, rng)
            if not owed:
                continue
            prof = scene.profiles[src.profile]
            # GCFM's agents are ellipses: its contact distance reaches 0.39 m each at walking speed
            size = 0.4 if model == "jupedsim-gcfm" else prof.radius if radius is None else radius
            centres, reach = _jps_discs(sim, size)
            spots = inflow.place(
                k,
                owed,
                centres=centres,
                reach=reach,
                radius=size,
                rng=rng,
                on_mesh=functools.partial(inside, r=prof.radius),
            )
            for p in spots:
                ids[sim.add_agent(params(p, src.state, prof))] = len(ids)
            inflow.entered(k, len(spots), t)
        if i % every == 0:
            frames.append((t, {ids[a.id]: (a.position[0], a.position[1]) for a in sim.agents()}))
        if i < steps:
            sim.iterate()
    wall = time.perf_counter() - t0
    n = len(ids)
    tt = np.asarray([f[0] for f in frames])
    pos = np.full((len(frames), n, 2), np.nan)
    for k, (_, agents) in enumerate(frames):
        if agents:
            cols = np.fromiter(agents.keys(), np.int64)
            pos[k, cols] = np.asarray(list(agents.values()))
    run = from_arrays(
        tt,
        pos,
        ids=np.arange(n),
        fps=fps,
        label=f"{case.name} {model}",
        meta={"scene": scene.name, "seed": start.seed, "condition": model},
    )
    return run, {"wall_s": round(wall, 2), "agents_added": n, "removed": n - sim.agent_count()}


def _jps_discs(sim: Any, default_radius: float) -> tuple[np.ndarray, np.ndarray]:
    """JuPedSim's agents as discs (centres, radii) for :meth:`pedvr.inflow.Inflow.place`; models
    without a radius (GCFM's ellipses) count as ``default_radius``."""
    agents = list(sim.agents())
    if not agents:
        return np.zeros((0, 2)), np.zeros(0)
    pos = np.asarray([a.position for a in agents], np.float64).reshape(-1, 2)
    rad = np.asarray([float(getattr(a.model, "radius", default_radius)) for a in agents])
    return pos, rad


def _setup(case: Case, walkable: shapely.Polygon, cutoff: float | None) -> Setup:
    return Setup(walkable=walkable, area=case.area, line=case.line, cutoff=cutoff)


def _references(case: Case, m: dict[str, Any], real: dict[str, Any] | None) -> dict[str, dict[str, Any]]:
    """Each reported measure: its value, the real one and the published one, and the errors."""
    out: dict[str, dict[str, Any]] = {}
    for key in REPORTED:
        v = m.get(key)
        r = None if real is None else real.get(key)
        p = case.published.get(key)
        if case.kind == "corridor" and key == "speed_mps" and m.get("density_per_m2") is not None:
            p = round(float(ref.weidmann_speed(float(m["density_per_m2"]))), 4)
        if v is None and r is None and p is None:
            continue
        out[key] = {
            "value": v,
            "real": r,
            "rel_error_real": rel_error(v, r),
            "published": p,
            "rel_error_published": rel_error(v, p),
        }
    return out


def run_case(
    case: Case,
    *,
    models: Sequence[str],
    duration: float | None,
    seed: int | None,
    data: Path | None,
    fps: float = DEFAULT_FPS,
    cutoff: float | None = None,
    plots: Path | None = None,
    jupedsim_radius: float | None = None,
) -> dict[str, Any]:
    """One case: the real recording (when at hand) and every model, measured and compared."""
    dur = case.duration if duration is None else duration
    out: dict[str, Any] = {
        "case": case.name,
        "title": case.title,
        "scene": case.scene,
        "duration_s": dur,
        "published_source": case.published_source,
        "runs": {},
    }
    runs: dict[str, tuple[Run, Measures]] = {}
    real_m: dict[str, Any] | None = None
    path = real_file(case, data)
    if path is not None and case.real is not None:
        run = load_real(path, unit=case.real.unit, fps=case.real.fps, label=f"{case.name} real")
        mm = measure(run, _setup(case, case.real.walkable, cutoff))
        real_m = _measures_dict(mm, run.agents)
        out["runs"]["real"] = {"measures": real_m, "file": str(path)}
        runs["real"] = (run, mm)
    elif case.real is not None:
        out["real_missing"] = f"{case.real.file} not in the data folder" if data else "no data folder given"
    from pedvr.scene.loader import load_any

    walk = walkable_polygon(load_any(case.scene_path(), seed=None).world)
    for model in models:
        try:
            if model in PEDVR_MODELS:
                run, info = run_pedvr(case, condition=model, duration=dur, seed=seed, fps=fps)
            else:
                run, info = run_jupedsim(
                    case, model=model, duration=dur, seed=seed, fps=fps, radius=jupedsim_radius
                )
            mm = measure(run, _setup(case, walk, cutoff))
        except Exception as exc:  # one broken run is reported in the result; the others go on
            traceback.print_exc()
            out["runs"][model] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        md = _measures_dict(mm, _expected_agents(case, run.agents))
        out["runs"][model] = {"measures": md, "references": _references(case, md, real_m), "run": info}
        runs[model] = (run, mm)
    if plots is not None:
        from pedvr.measure.plots import plot_case

        out["plots"] = [str(p) for p in plot_case(case, runs, folder=plots)]
    out["_series"] = {k: m for k, (_, m) in runs.items()}
    return out


def run_realism(
    *,
    cases: Sequence[str] | None = None,
    models: Sequence[str] | None = None,
    duration: float | None = None,
    seed: int | None = None,
    data: str | Path | None = None,
    fps: float = DEFAULT_FPS,
    cutoff: float | None = None,
    plots: Path | None = None,
    jupedsim_radius: float | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """The whole benchmark (see the module docstring); a JSON-ready dict."""
    names = list(cases or DEFAULT_CASES)
    chosen = [get_case(n) for n in names]
    wanted = list(models or DEFAULT_MODELS)
    bad = [m for m in wanted if m not in MODELS]
    if bad:
        raise MeasureError(f"--models {bad[0]!r}: unknown; known: {', '.join(MODELS)}")
    skipped = []
    if not have_jupedsim():
        skipped = [m for m in wanted if m in JUPEDSIM_MODELS]
        wanted = [m for m in wanted if m not in JUPEDSIM_MODELS]
    folder = data_dir(data)
    t0 = time.perf_counter()
    results = []
    for case in chosen:
        if progress is not None:
            progress(f"realism: {case.name} ({', '.join(wanted)})")
        results.append(
            run_case(
                case,
                models=wanted,
                duration=duration,
                seed=seed,
                data=folder,
                fps=fps,
                cutoff=cutoff,
                plots=plots,
                jupedsim_radius=jupedsim_radius,
            )
        )
    pooled: dict[str, Any] = {}
    for model in (["real"] if folder is not None else []) + wanted:
        rho, v = [], []
        for r in results:
            m = r["_series"].get(model)
            if m is None or CASES[r["case"]].kind != "corridor" or not m.series or m.steady_s is None:
                continue
            t = m.series["t"]
            sel = (t >= m.steady_s[0]) & (t <= m.steady_s[1])
            rho.append(m.series["density"][sel])
            v.append(m.series["speed"][sel])
        if rho:
            s = fd_slope(np.concatenate(rho), np.concatenate(v))
            pooled[model] = {"slope_dv_drho": None if s is None else round(s, 4)}
    if "real" in pooled:
        for model, d in pooled.items():
            if model != "real":
                d["rel_error_real"] = rel_error(d["slope_dv_drho"], pooled["real"]["slope_dv_drho"])
    for r in results:
        del r["_series"]
    return {
        "benchmark": "realism",
        "models": wanted,
        "models_skipped": {m: "jupedsim is not installed (pip install -e '.[bench]')" for m in skipped},
        "data": None if folder is None else str(folder),
        "seed": seed,
        "fps": fps,
        "jupedsim_radius": jupedsim_radius,
        "cases": results,
        "corridor_pooled": pooled,
        "wall_s": round(time.perf_counter() - t0, 1),
        "load_1min": round(os.getloadavg()[0], 2),
        "cpus": os.cpu_count(),
    }


def table(result: dict[str, Any]) -> str:
    """The benchmark as a Markdown table: one row per case and measure, one column per source."""
    models = (["real"] if result.get("data") else []) + list(result["models"])
    head = "| case | measure | " + " | ".join(models) + " | published |"
    lines = [head, "|" + "---|" * (len(models) + 3)]
    for c in result["cases"]:
        runs = c["runs"]
        for key in REPORTED:
            vals = [runs.get(m, {}).get("measures", {}).get(key) for m in models]
            pub = None
            for m in models:
                refs = runs.get(m, {}).get("references", {}).get(key)
                if refs and refs.get("published") is not None and pub is None:
                    pub = refs["published"] if key != "speed_mps" else "Weidmann(ρ)"
            if all(v is None for v in vals):
                continue
            cells = []
            for m, v in zip(models, vals, strict=True):
                e = runs.get(m, {}).get("references", {}).get(key, {}).get("rel_error_real")
                cells.append("—" if v is None else f"{v:g}" + (f" ({e:+.0%})" if e is not None else ""))
            lines.append(
                f"| {c['case']} | {key} | " + " | ".join(cells) + f" | {'' if pub is None else pub} |"
            )
    pooled = result.get("corridor_pooled", {})
    if pooled:
        lines.append(
            "| corridors pooled | slope dv/dρ | "
            + " | ".join(
                "—" if pooled.get(m, {}).get("slope_dv_drho") is None else f"{pooled[m]['slope_dv_drho']:g}"
                for m in models
            )
            + " | Weidmann: negative |"
        )
    return "\n".join(lines)
