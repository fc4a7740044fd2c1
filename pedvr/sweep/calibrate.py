"""Calibration of the coupled model's free parameters against real experiments, on Dask (issue 26 item 4).

``python -m pedvr.sweep.calibrate SPEC.toml [--workers N] [--data DIR] [--out DIR] [--json]``

A calibration spec (``sweeps/calibration.toml``) names validation cases (:mod:`pedvr.measure.cases`),
the measures to fit, the ``[steering]`` parameters to vary with their ranges, and a space-filling
design of ``points`` parameter sets drawn with :mod:`scipy.stats.qmc` (a scrambled Sobol' sequence,
Halton, or a Latin hypercube; seeded, so the same spec gives the same points). Every point x case is
one task on Dask (a LocalCluster of ``--workers`` processes, as :mod:`pedvr.sweep.runner` starts
them; ``--workers 0`` runs them in this process): the case's scene with the point's parameters, run
headless for ``duration`` simulated seconds and measured with PedPy exactly as ``pedvr bench realism``
measures it (:mod:`pedvr.measure.realism`).

The objective is the realism error of ``pedvr bench realism``: the mean over cases x measures of
``|value - reference| / reference``, the reference being the real recording's measure where the data
folder has it and the published relation's otherwise (the corridors' speed: Weidmann's at the run's
density). A measure the run could not give (too few crossings) counts as an error of 1 (100 %). A
point whose runs leave two bodies overlapping by more than 1 cm is not eligible as the best one,
whatever its error: the model's safety is not traded for fit.

The sensitivity table gives, per parameter, Spearman's rank correlation with the objective and with
each (case, measure)'s signed error over the design, and the standardised regression coefficient of
a linear fit of the objective on all parameters (with the fit's R^2). With a handful of points these
are indications, not estimates: the spec says how many points it ran.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from pedvr.measure.errors import MeasureError
from pedvr.scene.config import TURNED_DEPTH_RATIO, SteeringParams
from pedvr.sweep.errors import SweepError

METHODS = ("sobol", "halton", "lhs")
MEASURES = ("flow_per_s", "speed_mps", "density_per_m2", "time_gap_median_s", "passed_share")
MISSING_ERROR = 1.0  # a measure the run did not give counts as 100 % off
_FLOAT_PARAMS = tuple(f.name for f in dataclasses.fields(SteeringParams) if f.type in ("float", float))
# Where each parameter is meaningful (the scene loader's own checks, scenes/README.md [steering]).
_LIMITS = {"depth_ratio": (TURNED_DEPTH_RATIO, 1.0), "time_gap": (0.0, math.inf),
           "user_responsibility": (0.0, 1.0)}


class CalibrationError(SweepError):
    """A calibration spec or its run cannot go on; one line naming the key and why."""


@dataclass(frozen=True)
class CalibrationSpec:
    """A parsed calibration spec (see the module docstring; every key in sweeps/calibration.toml)."""

    name: str
    cases: tuple[str, ...]
    measures: tuple[str, ...]
    duration: float | None
    seed: int
    method: str
    points: int
    design_seed: int
    parameters: dict[str, tuple[float, float]]
    source: str = ""


def parse_calibration(data: dict[str, Any], *, source: str) -> CalibrationSpec:
    """The spec from a TOML table; :class:`CalibrationError` names the first bad key."""
    from pedvr.measure.cases import CASES

    cal = data.get("calibration")
    if not isinstance(cal, dict):
        raise CalibrationError(f"{source}: no [calibration] table")

    def bad(key: str, value: Any, expect: str) -> CalibrationError:
        return CalibrationError(f"{source}: calibration.{key} = {value!r}: {expect}")

    name = cal.get("name", Path(source).stem)
    if not isinstance(name, str) or not name or "/" in name:
        raise bad("name", name, "must be a non-empty name without '/'")
    cases = cal.get("cases")
    if not isinstance(cases, list) or not cases or any(c not in CASES for c in cases):
        raise bad("cases", cases, f"must be a non-empty list of {', '.join(CASES)}")
    measures = cal.get("measures", ["flow_per_s", "speed_mps", "density_per_m2"])
    if not isinstance(measures, list) or not measures or any(m not in MEASURES for m in measures):
        raise bad("measures", measures, f"must be a non-empty list of {', '.join(MEASURES)}")
    duration = cal.get("duration")
    if duration is not None and not (isinstance(duration, (int, float)) and not isinstance(duration, bool)
                                     and 0 < duration <= 3600):
        raise bad("duration", duration, "must be simulated seconds in (0, 3600] (none: each case's own)")
    seed = cal.get("seed", 1)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise bad("seed", seed, "must be an integer >= 0")
    design = cal.get("design", {})
    if not isinstance(design, dict):
        raise bad("design", design, "must be a table")
    method = design.get("method", "sobol")
    if method not in METHODS:
        raise bad("design.method", method, f"must be one of {', '.join(METHODS)}")
    points = design.get("points")
    if not isinstance(points, int) or isinstance(points, bool) or not 2 <= points <= 4096:
        raise bad("design.points", points, "must be an integer in [2, 4096]")
    if method == "sobol" and points & (points - 1):
        raise bad("design.points", points, "must be a power of 2 for a Sobol' design (its balance needs it)")
    design_seed = design.get("seed", 0)
    if not isinstance(design_seed, int) or isinstance(design_seed, bool) or design_seed < 0:
        raise bad("design.seed", design_seed, "must be an integer >= 0")
    params = cal.get("parameters")
    if not isinstance(params, dict) or not params:
        raise CalibrationError(f"{source}: [calibration.parameters] must name a [steering] parameter or more")
    ranges: dict[str, tuple[float, float]] = {}
    for key, rng in params.items():
        if key not in _FLOAT_PARAMS:
            raise bad(f"parameters.{key}", rng, f"unknown; a [steering] number: {', '.join(_FLOAT_PARAMS)}")
        lo_ok, hi_ok = _LIMITS.get(key, (0.0, math.inf))
        if (not isinstance(rng, list) or len(rng) != 2
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in rng)
                or not (math.isfinite(rng[0]) and math.isfinite(rng[1]) and rng[0] < rng[1])
                or rng[0] < lo_ok or rng[1] > hi_ok):
            raise bad(f"parameters.{key}", rng, f"must be [low, high], low < high, within [{lo_ok}, {hi_ok}]")
        ranges[key] = (float(rng[0]), float(rng[1]))
    return CalibrationSpec(name=name, cases=tuple(cases), measures=tuple(measures),
                           duration=None if duration is None else float(duration), seed=seed, method=method,
                           points=points, design_seed=design_seed, parameters=ranges, source=source)


def load_calibration(path: str | Path) -> CalibrationSpec:
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except OSError as exc:
        raise CalibrationError(f"{p}: cannot read it ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise CalibrationError(f"{p}: not TOML ({exc})") from None
    return parse_calibration(data, source=str(p))


def design(spec: CalibrationSpec) -> np.ndarray:
    """``(points, parameters)``: the space-filling design in parameter units (scipy.stats.qmc),
    the same for the same spec."""
    from scipy.stats import qmc

    k = len(spec.parameters)
    if spec.method == "sobol":
        sampler: Any = qmc.Sobol(d=k, scramble=True, seed=spec.design_seed)
        unit = sampler.random_base2(int(round(math.log2(spec.points))))
    elif spec.method == "halton":
        unit = qmc.Halton(d=k, scramble=True, seed=spec.design_seed).random(spec.points)
    else:
        unit = qmc.LatinHypercube(d=k, seed=spec.design_seed).random(spec.points)
    lo = np.array([r[0] for r in spec.parameters.values()])
    hi = np.array([r[1] for r in spec.parameters.values()])
    return np.asarray(qmc.scale(unit, lo, hi))


def reference_measures(case_name: str, data: Path | None) -> dict[str, Any] | None:
    """The real recording's measures for ``case_name`` (None: no real data for it)."""
    from pedvr.measure.cases import get_case, real_file
    from pedvr.measure.measures import measure
    from pedvr.measure.realism import _measures_dict, _setup
    from pedvr.measure.trajectories import load_real

    case = get_case(case_name)
    path = real_file(case, data)
    if path is None or case.real is None:
        return None
    run = load_real(path, unit=case.real.unit, fps=case.real.fps, label=f"{case.name} real")
    return _measures_dict(measure(run, _setup(case, case.real.walkable, None)), run.agents)


def run_point(case_name: str, params: dict[str, float], duration: float | None, seed: int,
              real: dict[str, Any] | None, measures: tuple[str, ...]) -> dict[str, Any]:
    """One task: the case's scene with ``params`` in its ``[steering]``, run coupled and measured as
    ``pedvr bench realism`` does; each measure's value, reference and error."""
    from pedvr.measure.cases import get_case
    from pedvr.measure.measures import measure, walkable_polygon
    from pedvr.measure.realism import _expected_agents, _measures_dict, _references, _setup
    from pedvr.measure.trajectories import from_simulation
    from pedvr.scene.loader import load_any
    from pedvr.sim import Simulation

    case = get_case(case_name)
    scene = load_any(case.scene_path(), seed=seed)
    steering: Any = scene.steering  # the spec checked every key names a float [steering] field
    scene = dataclasses.replace(scene, steering=dataclasses.replace(steering, **params))
    sim = Simulation(scene, seed=seed, condition="pedvr", record=True)
    t0 = time.perf_counter()
    sim.advance_to(case.duration if duration is None else duration)
    wall = time.perf_counter() - t0
    s = sim.summary()
    run = from_simulation(sim, label=f"{case.name} calibration")
    md = _measures_dict(measure(run, _setup(case, walkable_polygon(scene.world), None)),
                        _expected_agents(case, run.agents))
    refs = _references(case, md, real)
    errors: dict[str, float | None] = {}
    for key in measures:
        r = refs.get(key)
        if r is None or (r["real"] is None and r["published"] is None):
            errors[key] = None  # nothing to compare with: not part of the objective
            continue
        err = r["rel_error_real"] if r["real"] is not None else r["rel_error_published"]
        errors[key] = MISSING_ERROR if err is None else float(err)
    return {"case": case_name, "params": params, "values": {k: md.get(k) for k in measures},
            "errors": errors, "overlaps_over_1cm": int(s["overlaps_over_1cm"]),  # type: ignore[call-overload]
            "stalled_agents": int(s["stalled_agents"]), "wall_s": round(wall, 2)}  # type: ignore[call-overload]


def objective(rows: list[dict[str, Any]]) -> float:
    """The mean absolute relative error over the rows' compared measures (see the module docstring)."""
    errs = [abs(e) for r in rows for e in r["errors"].values() if e is not None]
    return float(np.mean(errs)) if errs else math.inf


def sensitivity(x: np.ndarray, y: np.ndarray, names: list[str],
                columns: dict[str, np.ndarray] | None = None) -> list[dict[str, Any]]:
    """Per parameter (column of ``x``): Spearman's ρ with ``y`` and with each of ``columns``, and the
    standardised regression coefficient of the linear fit of ``y`` on every parameter (plus its R²)."""
    from scipy.stats import spearmanr

    xs = (x - x.mean(axis=0)) / np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
    ok = np.isfinite(y)
    ys = (y[ok] - y[ok].mean()) / (y[ok].std() or 1.0)
    a = np.column_stack([xs[ok], np.ones(int(ok.sum()))])
    coef, *_ = np.linalg.lstsq(a, ys, rcond=None)
    fit = a @ coef
    varies = bool(ok.sum() > len(names) + 1 and np.ptp(y[ok]) > 0)  # a fit with fewer points says nothing
    r2 = 1.0 - float(((ys - fit) ** 2).sum()) / float((ys ** 2).sum()) if varies else None

    def rho(u: np.ndarray, v: np.ndarray) -> float | None:
        good = np.isfinite(u) & np.isfinite(v)
        if good.sum() < 3 or np.ptp(v[good]) == 0 or np.ptp(u[good]) == 0:
            return None
        return round(float(spearmanr(u[good], v[good]).statistic), 3)

    out = []
    for k, name in enumerate(names):
        row: dict[str, Any] = {"parameter": name, "spearman_objective": rho(x[:, k], y),
                               "src_objective": round(float(coef[k]), 3) if varies else None,
                               "r2_linear": None if r2 is None else round(r2, 3)}
        for col, v in (columns or {}).items():
            row[f"spearman {col}"] = rho(x[:, k], v)
        out.append(row)
    return out


def calibrate(spec: CalibrationSpec, *, workers: int | None = None, data: str | Path | None = None,
              client: Any = None, progress: TextIO | None = None) -> dict[str, Any]:
    """Run the spec's design (see the module docstring); a JSON-ready dict."""
    from pedvr.measure.cases import data_dir

    folder = data_dir(data)
    names = list(spec.parameters)
    pts = design(spec)
    real = {c: reference_measures(c, folder) for c in spec.cases}
    jobs = [(i, c) for i in range(len(pts)) for c in spec.cases]
    args = [(c, {n: round(float(pts[i, k]), 6) for k, n in enumerate(names)}, spec.duration, spec.seed,
             real[c], spec.measures) for i, c in jobs]
    t0 = time.perf_counter()
    closers: list[Any] = []
    if workers == 0 and client is None:
        results = [run_point(*a) for a in args]
    else:
        if client is None:
            from pedvr.sweep.runner import start_local_cluster

            client, closers = start_local_cluster(workers)
        try:
            futures = [client.submit(run_point, *a, key=f"calibrate-{spec.name}-{i}-{c}", pure=False)
                       for (i, c), a in zip(jobs, args, strict=True)]
            results = []
            for f in futures:
                results.append(f.result())
                if progress is not None:
                    r = results[-1]
                    print(f"calibrate: {len(results)} of {len(jobs)} runs ({r['case']}, {r['wall_s']} s)",
                          file=progress, flush=True)
        finally:
            for c in reversed(closers):
                c.close()
    per_point = []
    for i in range(len(pts)):
        rows = [r for (j, _), r in zip(jobs, results, strict=True) if j == i]
        per_point.append({
            "point": i, "params": rows[0]["params"], "objective": round(objective(rows), 4),
            "overlaps_over_1cm": sum(r["overlaps_over_1cm"] for r in rows),
            "stalled_agents": sum(r["stalled_agents"] for r in rows),
            "errors": {f"{r['case']} {k}": v for r in rows for k, v in r["errors"].items()},
            "values": {f"{r['case']} {k}": v for r in rows for k, v in r["values"].items()},
        })
    eligible = [p for p in per_point if p["overlaps_over_1cm"] == 0 and math.isfinite(p["objective"])]
    best = min(eligible, key=lambda p: (p["objective"], p["point"])) if eligible else None
    y = np.array([p["objective"] for p in per_point], dtype=float)
    cols = sorted({k for p in per_point for k, v in p["errors"].items() if v is not None})
    columns = {k: np.array([np.nan if p["errors"].get(k) is None else p["errors"][k] for p in per_point])
               for k in cols}
    import os

    return {"calibration": spec.name, "spec": spec.source, "cases": list(spec.cases),
            "measures": list(spec.measures), "duration_s": spec.duration, "seed": spec.seed,
            "design": {"method": spec.method, "points": spec.points, "seed": spec.design_seed,
                       "parameters": {k: list(v) for k, v in spec.parameters.items()}},
            "data": None if folder is None else str(folder),
            "references": {c: ("real" if real[c] is not None else "published") for c in spec.cases},
            "points": per_point, "best": best,
            "sensitivity": sensitivity(pts, y, names, columns),
            "wall_s": round(time.perf_counter() - t0, 1), "load_1min": round(os.getloadavg()[0], 2),
            "cpus": os.cpu_count()}


def _f(v: Any) -> str:
    return "—" if v is None else (f"{v:.3g}" if isinstance(v, float) else str(v))


def table(result: dict[str, Any]) -> str:
    """The design, its best point and the sensitivity table, as Markdown."""
    names = list(result["design"]["parameters"])
    cols = sorted({k for p in result["points"] for k in p["errors"]})
    out = [f"calibration {result['calibration']}: {result['design']['method']} design, "
           f"{result['design']['points']} points x {len(result['cases'])} cases, "
           f"{result['duration_s'] or 'each case its own'} s simulated, seed {result['seed']}; "
           f"references {result['references']}; {result['wall_s']} s wall, load {result['load_1min']}", "",
           "| point | " + " | ".join(names) + " | objective | overlaps | " + " | ".join(cols) + " |",
           "|---" * (len(names) + len(cols) + 3) + "|"]
    for p in result["points"]:
        out.append(f"| {p['point']} | " + " | ".join(_f(p["params"][n]) for n in names)
                   + f" | {_f(p['objective'])} | {p['overlaps_over_1cm']} | "
                   + " | ".join(_f(p["errors"].get(c)) for c in cols) + " |")
    b = result["best"]
    out += ["", "best: none eligible" if b is None else
            "best: point " + str(b["point"]) + " (" + ", ".join(f"{n} = {b['params'][n]}" for n in names)
            + f"), mean |error| {b['objective']}", "", "sensitivity (Spearman's rho over the design; SRC: "
            "standardised regression coefficient of the objective):", ""]
    first = result["sensitivity"][0] if result["sensitivity"] else {}
    scols = [k for k in first if k.startswith("spearman ")]
    out.append("| parameter | rho objective | SRC objective | R² linear | "
               + " | ".join(k.removeprefix("spearman ") for k in scols) + " |")
    out.append("|---" * (4 + len(scols)) + "|")
    for s in result["sensitivity"]:
        out.append(f"| {s['parameter']} | {_f(s['spearman_objective'])} | {_f(s['src_objective'])} | "
                   f"{_f(s['r2_linear'])} | " + " | ".join(_f(s[k]) for k in scols) + " |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None, *, stdout: TextIO | None = None) -> int:
    out_stream = stdout or sys.stdout
    ap = argparse.ArgumentParser(prog="python -m pedvr.sweep.calibrate", description=__doc__.splitlines()[0])
    ap.add_argument("spec", help="calibration spec (sweeps/calibration.toml)")
    ap.add_argument("--workers", type=int, default=None, help="local Dask workers (default: one per core; "
                    "0: in this process)")
    ap.add_argument("--data", default=None, help="real-data folder (default: $PEDVR_REAL_DATA)")
    ap.add_argument("--out", default=None, help="write calibration.json and calibration.md in this folder")
    ap.add_argument("--json", action="store_true", help="print JSON (default: Markdown)")
    args = ap.parse_args(argv)
    try:
        if args.workers is not None and args.workers < 0:
            raise CalibrationError(f"--workers {args.workers}: must be >= 0")
        spec = load_calibration(args.spec)
        result = calibrate(spec, workers=args.workers, data=args.data, progress=sys.stderr)
    except (SweepError, MeasureError) as exc:  # a bad spec, data folder or case: one line
        print(f"pedvr calibrate: {exc}", file=sys.stderr)
        return 2

    if args.out:
        folder = Path(args.out)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "calibration.json").write_text(json.dumps(result, indent=2) + "\n")
        (folder / "calibration.md").write_text(table(result))
    print(json.dumps(result, indent=2) if args.json else table(result), file=out_stream)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
