"""``pedvr measure`` and ``pedvr bench realism``.

``pedvr measure INPUT... [--case NAME | --scene FILE] [--area X0 Y0 X1 Y1] [--line X0 Y0 X1 Y1]``
measures pedvr recordings (``.npz``) and real trajectory files (PeTrack ``.txt``, the
Jülich archive's ``.h5``) with the same code, side by side; ``--plot DIR`` writes the
plots; ``--json`` prints the measures as JSON.

``pedvr bench realism [--cases ...] [--models ...] [--duration S] [--data DIR] [--json]``
runs the validation cases (:mod:`pedvr.measure.realism`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, TextIO

import shapely

from pedvr.argtypes import positive
from pedvr.measure.cases import (
    CASES,
    DATA_HELP,
    Case,
    case_for_file,
    case_for_scene,
    data_dir,
    get_case,
    real_file,
)
from pedvr.measure.errors import MeasureError
from pedvr.measure.measures import Measures, Setup, measure, walkable_polygon
from pedvr.measure.trajectories import DEFAULT_FPS, Run, from_recording, load_real


def add_measure_parser(subparsers: Any) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "measure",
        help="the field's measures (PedPy) on recordings and real trajectories",
        description="Measure pedvr recordings (.npz) and real trajectory files (.txt, .h5) with PedPy, "
        "side by side: Voronoi density and speed in a measurement area, flow, time gaps and N(t) at a "
        "line, the steady state from the crossing times, the fundamental diagram.",
        epilog=f"Real data is not shipped: {DATA_HELP}. Cases: {', '.join(CASES)}.",
    )
    p.add_argument(
        "inputs",
        nargs="*",
        metavar="INPUT",
        help="recordings (.npz from pedvr run --record) and real trajectory files; none: the "
        "case's real recording from --data",
    )
    p.add_argument(
        "--case",
        default=None,
        help="a validation case: its walkable area, measurement area and "
        "line (default: found from the recording's scene or the real file's name)",
    )
    p.add_argument(
        "--scene",
        type=Path,
        default=None,
        help="scene file whose walkable area the inputs are measured in (default: the recording's)",
    )
    p.add_argument(
        "--area",
        type=float,
        nargs=4,
        metavar=("X0", "Y0", "X1", "Y1"),
        default=None,
        help="measurement area, a box (m)",
    )
    p.add_argument(
        "--line",
        type=float,
        nargs=4,
        metavar=("X0", "Y0", "X1", "Y1"),
        default=None,
        help="measurement line (m)",
    )
    p.add_argument(
        "--steady",
        type=float,
        nargs=2,
        metavar=("T0", "T1"),
        default=None,
        help="steady state (s) instead of the one drawn from the crossing times",
    )
    p.add_argument(
        "--fps",
        type=positive(float),
        default=DEFAULT_FPS,
        help="frames/s kept from a recording (default: %(default)s)",
    )
    p.add_argument(
        "--unit",
        choices=("m", "cm"),
        default=None,
        help="unit of a real .txt file whose header does not say (default: the case's)",
    )
    p.add_argument(
        "--input-fps",
        type=positive(float),
        default=None,
        help="frame rate of a real .txt file whose header does not say (default: the case's)",
    )
    p.add_argument("--cutoff", type=positive(float), default=None,
                   help="Voronoi cut-off radius (m; default: none)")
    p.add_argument("--data", default=None, help="real-data folder (default: $PEDVR_REAL_DATA)")
    p.add_argument("--plot", type=Path, default=None, metavar="DIR", help="write the plots (PNG) here")
    p.add_argument("--json", action="store_true")
    return p


def add_realism_parser(bench_subparsers: Any) -> argparse.ArgumentParser:
    from pedvr.measure.realism import DEFAULT_MODELS, MODELS

    b = bench_subparsers.add_parser(
        "realism",
        help="validation scenes against real experiments and published relations (PedPy)",
        description="Run the validation scenes (scenes/validation) with pedvr's models and JuPedSim's "
        "(where installed), measure them with PedPy like the real recordings, and report each measure "
        "against its references with the relative error.",
        epilog=DATA_HELP,
    )
    b.add_argument(
        "--cases",
        nargs="+",
        default=None,
        metavar="CASE",
        help=f"cases (default: the standard set); known: {', '.join(CASES)}",
    )
    b.add_argument(
        "--models",
        nargs="+",
        default=None,
        metavar="MODEL",
        help=f"models (default: {' '.join(DEFAULT_MODELS)}); known: {', '.join(MODELS)}",
    )
    b.add_argument(
        "--duration",
        type=positive(float),
        default=None,
        help="simulated seconds per run (default: each case's, 90-140 s)",
    )
    b.add_argument("--seed", type=int, default=None, help="seed (default: the scenes')")
    b.add_argument("--data", default=None, help="real-data folder (default: $PEDVR_REAL_DATA)")
    b.add_argument(
        "--fps", type=positive(float), default=DEFAULT_FPS, help="frames/s measured (default: %(default)s)"
    )
    b.add_argument("--plot", type=Path, default=None, metavar="DIR", help="write each case's plots here")
    b.add_argument(
        "--jupedsim-radius",
        type=positive(float),
        default=None,
        metavar="R",
        help="radius (m) of JuPedSim's agents (default: the scene profile's, as pedvr's; JuPedSim's: 0.2)",
    )
    b.add_argument("--out", type=Path, default=None, metavar="FILE", help="also write the JSON here")
    b.add_argument("--json", action="store_true", help="print JSON (default: a Markdown table)")
    return b


def _scene_walkable(path: Path | str) -> tuple[shapely.Polygon, str]:
    from pedvr.scene.loader import load_any
    from pedvr.scenes import resolve_scene

    p = resolve_scene(str(path))
    scene = load_any(p, seed=None)
    return walkable_polygon(scene.world), scene.name


def _load(
    path: Path, args: argparse.Namespace, case: Case | None
) -> tuple[Run, Case | None, shapely.Polygon]:
    if path.suffix == ".npz":
        run = from_recording(path, fps=args.fps)
        c = case or case_for_scene(str(run.meta.get("scene", "")))
        scene = args.scene or run.source or (c.scene if c is not None else None)
        if scene is None:
            raise MeasureError(f"{path}: the recording names no scene file; give --scene FILE")
        try:
            walk, _ = _scene_walkable(scene)
        except MeasureError:
            raise
        except Exception as exc:  # a scene that moved or no longer loads
            if c is None:
                raise MeasureError(
                    f"{path}: its scene {scene} cannot be loaded ({exc}); give --scene FILE"
                ) from None
            walk, _ = _scene_walkable(c.scene)
        return run, c, walk
    c = case or case_for_file(path)
    unit = args.unit or (c.real.unit if c is not None and c.real is not None else None)
    fps = args.input_fps or (c.real.fps if c is not None and c.real is not None else None)
    run = load_real(path, unit=unit, fps=fps)
    if args.scene is not None:
        walk, _ = _scene_walkable(args.scene)
    elif c is not None and c.real is not None:
        walk = c.real.walkable
    else:
        raise MeasureError(f"{path}: no walkable area known for this file; give --case NAME or --scene FILE")
    return run, c, walk


def _setup(args: argparse.Namespace, case: Case | None, walk: shapely.Polygon, label: str) -> Setup:
    area = (
        shapely.box(*_ordered(args.area, "--area"))
        if args.area is not None
        else (case.area if case is not None else None)
    )
    line = (
        ((args.line[0], args.line[1]), (args.line[2], args.line[3]))
        if args.line is not None
        else (case.line if case is not None else None)
    )
    if args.line is not None and args.line[:2] == args.line[2:]:
        raise MeasureError(f"--line {' '.join(map(str, args.line))}: the two points must differ")
    if area is None and line is None:
        raise MeasureError(f"{label}: nothing to measure: give --area and/or --line, or --case NAME")
    if area is not None and not walk.intersects(area):
        raise MeasureError(
            f"{label}: the measurement area {list(area.bounds)} lies outside the walkable area"
        )
    return Setup(walkable=walk, area=area, line=line, cutoff=args.cutoff)


def _ordered(v: list[float], flag: str) -> tuple[float, float, float, float]:
    x0, y0, x1, y1 = v
    if not (x1 > x0 and y1 > y0):
        raise MeasureError(f"{flag} {' '.join(map(str, v))}: expected X0 Y0 X1 Y1 with X1 > X0 and Y1 > Y0")
    return x0, y0, x1, y1


def run_measure_command(args: argparse.Namespace, *, stdout: TextIO | None = None) -> int:
    out = stdout or sys.stdout
    case = get_case(args.case) if args.case is not None else None
    inputs = [Path(p) for p in args.inputs]
    if not inputs:
        if case is None:
            raise MeasureError(
                "pedvr measure: give INPUT files, or --case NAME with --data DIR for its real recording"
            )
        real = real_file(case, data_dir(args.data))
        if real is None:
            raise MeasureError(f"case {case.name}: its real recording is not at hand ({DATA_HELP})")
        inputs = [real]
    runs: dict[str, tuple[Run, Measures]] = {}
    setups: dict[str, Setup] = {}
    named = case
    for path in inputs:
        run, c, walk = _load(path, args, case)
        named = named or c
        setup = _setup(args, c, walk, str(path))
        m = measure(run, setup, steady=None if args.steady is None else (args.steady[0], args.steady[1]))
        label = run.label
        while label in runs:
            label += "'"
        runs[label] = (run, m)
        setups[label] = setup
    results = [m.summary() for _, m in runs.values()]
    if args.plot is not None:
        from pedvr.measure.plots import plot_runs

        name = named.name if named is not None else inputs[0].stem
        files = plot_runs(runs, setups, folder=args.plot, name=name)
        for r in results:
            r["plots"] = [str(f) for f in files]
    if args.json:
        print(json.dumps(results, indent=2), file=out)
        return 0
    keys = (
        "agents",
        "crossed",
        "flow_per_s",
        "time_gap_median_s",
        "density_per_m2",
        "speed_mps",
        "slope_dv_drho",
        "steady_s",
    )
    print("| run | " + " | ".join(keys) + " |", file=out)
    print("|" + "---|" * (len(keys) + 1), file=out)
    for r in results:
        print(
            f"| {r['label']} | " + " | ".join("—" if r[k] is None else str(r[k]) for k in keys) + " |",
            file=out,
        )
    if args.plot is not None:
        print(f"plots: {args.plot}", file=out)
    return 0


def run_realism_command(args: argparse.Namespace, *, stdout: TextIO | None = None) -> int:
    from pedvr.measure.realism import run_realism, table

    out = stdout or sys.stdout
    if args.out is not None and args.out.is_dir():
        raise MeasureError(f"--out {args.out}: is a folder; give a file name")
    result = run_realism(
        cases=args.cases,
        models=args.models,
        duration=args.duration,
        seed=args.seed,
        data=args.data,
        fps=args.fps,
        plots=args.plot,
        jupedsim_radius=args.jupedsim_radius,
        progress=lambda msg: print(msg, file=sys.stderr),
    )
    text = json.dumps(result, indent=2)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    print(text if args.json else table(result), file=out)
    return 0
