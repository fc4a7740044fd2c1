"""The ``pedvr`` command line.

``pedvr run [SCENE]``          run a scene (default: antipodal_circle)
``pedvr scene check FILE...``  validate scene files; exit 2 on problems
``pedvr scene list``           the shipped scenes
``pedvr bench steering``       ORCA step time against RVO2

Errors a user can cause print as ``pedvr: error: ...`` lines and a non-zero
exit code, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from pedvr.errors import PedvrError, UsageError
from pedvr.scene.config import CONDITIONS
from pedvr.scenes import DEFAULT_SCENE, resolve_scene, shipped_scenes


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{self.prog}: {message}")


def _positive(kind: type) -> object:
    def parse(text: str) -> object:
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if v <= 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
        return v

    return parse


def _unit(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be in [0, 1]")
    return v


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="pedvr", description="Virtual pedestrians around a real user.")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    run = sub.add_parser("run", help="run a scene")
    run.add_argument("scene", nargs="?", default=None,
                     help=f"scene file (.toml, SteerSuite .xml) or shipped scene; default {DEFAULT_SCENE}")
    run.add_argument("--backend", default="auto", choices=("auto", "xr", "desktop", "headless"))
    run.add_argument("--duration", type=_positive(float), default=None, help="simulated seconds")
    run.add_argument("--seed", type=int, default=None, help="overrides the scene's seed")
    run.add_argument("--condition", default="pedvr", choices=CONDITIONS)
    run.add_argument("--responsibility", type=_unit, default=None,
                     help="share ρ of avoidance virtual agents take toward the user (0..1)")
    run.add_argument("--record", type=Path, default=None, help="trajectory file (.npz)")
    run.add_argument("--metrics-json", type=Path, default=None, help="metrics file (.json)")
    run.add_argument("--out", type=Path, default=Path("pedvr-out"),
                     help="folder for outputs not named explicitly (default ./pedvr-out)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")

    scene = sub.add_parser("scene", help="scene files")
    ssub = scene.add_subparsers(dest="scene_command", required=True, parser_class=_Parser)
    check = ssub.add_parser("check", help="validate scene files")
    check.add_argument("files", nargs="+")
    ssub.add_parser("list", help="list shipped scenes")

    bench = sub.add_parser("bench", help="benchmarks")
    bsub = bench.add_subparsers(dest="bench_command", required=True, parser_class=_Parser)
    st = bsub.add_parser("steering", help="antipodal-circle ORCA benchmark, optionally against RVO2")
    st.add_argument("--agents", type=_positive(int), action="append", default=None)
    st.add_argument("--vs", choices=("rvo2",), default=None)
    st.add_argument("--steps", type=_positive(int), default=None)
    st.add_argument("--json", action="store_true")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        if args.command == "run":
            return _run(args)
        if args.command == "scene":
            return _scene(args)
        return _bench(args)
    except PedvrError as exc:
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"pedvr: error: {line}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("pedvr: interrupted", file=sys.stderr)
        return 130


def _run(args: argparse.Namespace) -> int:
    from pedvr.scene.loader import load_any
    from pedvr.xr.select import choose_backend

    backend, why = choose_backend(args.backend)
    path = resolve_scene(args.scene)
    scene = load_any(path, seed=args.seed)
    print(why)
    from pedvr.headless import run_headless

    summary = run_headless(scene, duration=args.duration, seed=args.seed, condition=args.condition,
                           responsibility=args.responsibility, record=args.record,
                           metrics_json=args.metrics_json, out=args.out, progress=not args.quiet)
    return 0 if summary else 1


def _scene(args: argparse.Namespace) -> int:
    from pedvr.errors import SceneError
    from pedvr.scene.loader import load_scene

    if args.scene_command == "list":
        for p in shipped_scenes():
            print(p.stem)
        return 0
    status = 0
    for f in args.files:
        try:
            s = load_scene(f)
        except SceneError as exc:
            for line in exc.problems:
                print(line)
            status = 2
            continue
        n = sum(sp.count or len(sp.positions) for sp in s.spawns)
        print(f"{f}: ok: scene {s.name!r}, {n} agents, {len(s.world.obstacles)} obstacles, "
              f"{len(s.behavior.states)} states")
    return status


def _bench(args: argparse.Namespace) -> int:
    from pedvr.crowd.bench import run_steering_bench

    results = []
    for n in args.agents or [1000, 4000]:
        kw = {"steps": args.steps} if args.steps else {}
        t0 = time.perf_counter()
        r = run_steering_bench(n, vs_rvo2=args.vs == "rvo2", **kw)
        r["wall_s"] = round(time.perf_counter() - t0, 3)
        results.append(r)
        if not args.json:
            print(", ".join(f"{k}={v}" for k, v in r.items()))
    if args.json:
        print(json.dumps(results[0] if len(results) == 1 else results, indent=2))
    return 0
