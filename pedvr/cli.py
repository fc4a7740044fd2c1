"""The ``pedvr`` command line.

``pedvr run [SCENE]``          run a scene (default: antipodal_circle)
``pedvr prepare [SCENE...]``   compile what a run needs into numba's cache first (the README's set-up)
``pedvr scene check FILE...``  validate scene files; exit 2 on problems; warnings (bodies that
                               start overlapping, :mod:`pedvr.scene.checks`) are printed, exit 0
``pedvr scene list``           the shipped scenes
``pedvr bench steering``       ORCA step time against RVO2
``pedvr bench behavior``       behavior scheduler tick time (trees, events)
``pedvr bench place``          PLACE planning time per demonstration; step times with and without
``pedvr sweep SPEC.toml``      many headless runs on Dask (:mod:`pedvr.sweep`)
``pedvr bench sim``            a whole simulation step with full bodies (``--load K`` beside it,
                               ``--vs rvo2``: RVO2 steering the same crowd in the same loop)
``pedvr bench doors``          a whole step of the 4-door building with door etiquette (16 and 64)
``pedvr xr check``             the OpenXR runtime and headset: what a lab's methods section needs

Errors a user can cause print as ``pedvr: error: ...`` lines and a non-zero
exit code, never a traceback.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

from pedvr.argtypes import count as _non_negative
from pedvr.argtypes import field_of_view
from pedvr.argtypes import positive as _positive
from pedvr.errors import PedvrError, UsageError
from pedvr.scene.config import CONDITIONS, USER_WALKS
from pedvr.scenes import DEFAULT_SCENE, resolve_scene, shipped_scenes


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        # main() prints "pedvr: error: "; name the subcommand, not the program again.
        where = self.prog.removeprefix("pedvr").strip()
        hint = f"; see 'pedvr {where + ' ' if where else ''}--help'"
        raise UsageError(f"{where + ': ' if where else ''}{message}{hint}")


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Defaults in every option's help; descriptions keep their line breaks.

    An option whose help already says its default ("(default: the scene's ...)"), and one whose
    default is None or a flag's False, gets no "(default: None)" added after it."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        if "default" in text or action.default is None or action.default is False:
            return text
        return super()._get_help_string(action)


def _nonnegative(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(v) and 0.0 <= v <= 2.0):
        raise argparse.ArgumentTypeError(f"{text!r} must be in [0, 2] m")
    return v


def _unit(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be in [0, 1]")
    return v


CONDITION_HELP = """conditions (PedVR §6):
  decoupled  plain ORCA, no motion limits; the body follows the disc (the study baseline)
  pedvr      coupled: the body's motion limits inside ORCA, the body is the truth
  pedvr+g    coupled, and agents look at the user when the user approaches (PedVR eqs. 1-3)"""


def _version() -> str:
    """``pedvr.__version__``: the code that runs, not an install's metadata, which an editable
    install keeps from the day it was installed."""
    from pedvr import __version__

    return __version__


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="pedvr", description="Virtual pedestrians around a real user.")
    p.add_argument("--version", action="version", version=f"pedvr {_version()}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND",
                           title="commands")

    run = sub.add_parser("run", help="run a scene", formatter_class=_HelpFormatter,
                         description="Run a scene in a headset, a window or headless.",
                         epilog=CONDITION_HELP)
    run.add_argument("scene", nargs="?", default=DEFAULT_SCENE,
                     help="scene file (.toml, SteerSuite .xml) or shipped scene name")
    run.add_argument("--backend", default="auto", choices=("auto", "xr", "desktop", "headless"),
                     help="auto: OpenXR if a headset answers, else a window if there is a display, "
                          "else headless")
    run.add_argument("--duration", type=_positive(float), default=None,
                     help="simulated seconds (default: the scene's duration)")
    run.add_argument("--seed", type=_non_negative, default=None,
                     help="an integer >= 0 (default: the scene's seed)")
    run.add_argument("--condition", default="pedvr", choices=CONDITIONS,
                     help="crowd model (see conditions below)")
    run.add_argument("--responsibility", type=_unit, default=None,
                     help="share ρ of avoidance virtual agents take toward the user, 0..1 "
                          "(default: the scene's)")
    run.add_argument("--personal-space", type=_nonnegative, default=None, metavar="M",
                     help="metres agents keep from the user where there is room (default: the scene's, 0.3)")
    run.add_argument("--user-walk", default=None, choices=USER_WALKS,
                     help="headless user: walk the route straight, or react to agents like a person "
                          "(default: the scene's, straight)")
    run.add_argument("--record", type=Path, default=None,
                     help="trajectory file (.npz; default: OUT/SCENE-seedN-CONDITION.npz)")
    run.add_argument("--metrics-json", type=Path, default=None,
                     help="metrics file (.json; default: OUT/SCENE-seedN-CONDITION.json)")
    run.add_argument("--out", type=Path, default=Path("pedvr-out"),
                     help="folder for outputs not named explicitly")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--frames", type=Path, default=None, metavar="DIR",
                     help="headless: write first-person and overhead PNGs into DIR (offscreen, EGL)")
    run.add_argument("--video", type=Path, default=None, metavar="FILE",
                     help="headless: write an MP4 of the first-person and overhead views side by side")
    run.add_argument("--view", default="mono", choices=("mono", "sbs", "anaglyph", "overhead"),
                     help="first-person view: mono, side-by-side stereo, anaglyph, or overhead debug")
    run.add_argument("--width", type=_positive(int), default=None,
                     help="pixels per view (default 640 headless, 1280 desktop)")
    run.add_argument("--height", type=_positive(int), default=None,
                     help="pixels per view (default 360 headless, 720 desktop)")
    run.add_argument("--fps", type=_positive(float), default=30.0,
                     help="headless: frames per simulated second")
    run.add_argument("--label", default=None, choices=tuple("ABCDEFGH"),
                     help="condition label the HUD shows (blind studies: never the condition's name)")
    run.add_argument("--no-vsync", action="store_true", help="desktop: do not wait for the vertical blank")

    prep = sub.add_parser("prepare", help="compile what a run needs now, so the run starts at once",
                          description="Compile numba's kernels for the first steps of a scene (the default "
                                      "scene if none is named) into numba's cache, saying what it prepares: "
                                      "the first `pedvr run` after an install then starts at once. The "
                                      "README's set-up command runs it.")
    prep.add_argument("scenes", nargs="*", metavar="SCENE",
                      help=f"scenes to prepare (default: {DEFAULT_SCENE})")
    prep.add_argument("--condition", default="pedvr+g", choices=CONDITIONS,
                      help="the condition stepped (default: %(default)s, every phase of the step)")
    prep.add_argument("--view", action="store_true",
                      help="also what a headset, desktop or --frames run prepares before its first frame: "
                           "both twins of the parallel kernels and the procedural character's mesh")
    scene = sub.add_parser("scene", help="scene files (check, list)")
    ssub = scene.add_subparsers(dest="scene_command", required=True, parser_class=_Parser, metavar="ACTION")
    check = ssub.add_parser("check", help="validate scene files",
                            description="Validate scene files: every problem (exit 2) and every warning "
                                        "(printed as FILE: warning: ...; a file with warnings only exits 0).")
    check.add_argument("files", nargs="+")
    ssub.add_parser("list", help="list shipped scenes")

    bench = sub.add_parser("bench", help="benchmarks")
    bsub = bench.add_subparsers(dest="bench_command", required=True, parser_class=_Parser, metavar="BENCH")
    st = bsub.add_parser("steering", help="antipodal-circle ORCA benchmark, optionally against RVO2")
    st.add_argument("--agents", type=_positive(int), action="append", default=None)
    st.add_argument("--vs", choices=("rvo2",), default=None)
    st.add_argument("--steps", type=_positive(int), default=None)
    st.add_argument("--load", type=int, action="append", default=None, metavar="K",
                    help="busy processes beside the timed steps (repeatable: one run per value; default 0)")
    st.add_argument("--json", action="store_true")
    bd = bsub.add_parser("body", help="full-body layer ms per step beside the steering step")
    bd.add_argument("--agents", type=_positive(int), action="append", default=None)
    bd.add_argument("--steps", type=_positive(int), default=300)
    bd.add_argument("--json", action="store_true")
    bh = bsub.add_parser("behavior", help="scheduler tick: personal trees and running two-actor events")
    bh.add_argument("--agents", type=_positive(int), action="append", default=None)
    bh.add_argument("--events", type=int, default=20, help="conversations kept running (default 20)")
    bh.add_argument("--seconds", type=_positive(float), default=20.0, help="simulated seconds timed")
    bh.add_argument("--json", action="store_true")
    bp = bsub.add_parser("place", help="PLACE: planning time per demonstration; step times meanwhile")
    bp.add_argument("--scene", choices=("place_table", "gallery"), action="append", default=None)
    bp.add_argument("--queries", type=_positive(int), default=200, help="plans timed per scene (default 200)")
    bp.add_argument("--seconds", type=_positive(float), default=30.0, help="simulated seconds of each run")
    bp.add_argument("--json", action="store_true")
    sb = bsub.add_parser("sim", help="whole Simulation.step() with full bodies on a generated plaza")
    sb.add_argument("--agents", type=_positive(int), action="append", default=None,
                    help="agents on the plaza (repeatable; default 100 and 1000)")
    sb.add_argument("--steps", type=_positive(int), default=450, help="timed steps (default: %(default)s)")
    sb.add_argument("--warmup", type=int, default=180, help="untimed steps first (default: %(default)s)")
    sb.add_argument("--load", type=int, action="append", default=None, metavar="K",
                    help="busy processes beside the timed steps (repeatable: one run per value; default 0)")
    sb.add_argument("--vs", choices=("rvo2",), default=None,
                    help="also step RVO2 (pyrvo) on the same crowd in the same loop, steering only")
    sb.add_argument("--json", action="store_true")
    dr = bsub.add_parser("doors", help="a whole step of the 4-door building with door etiquette, full bodies")
    dr.add_argument("--agents", type=_positive(int), action="append", default=None,
                    help="pedestrians in the building (repeatable; default 16 and 64)")
    dr.add_argument("--steps", type=_positive(int), default=900, help="timed steps (default: %(default)s)")
    dr.add_argument("--warmup", type=int, default=300, help="untimed steps first (default: %(default)s)")
    dr.add_argument("--json", action="store_true")
    rb = bsub.add_parser("render", help="crowd rendering cost, stereo, offscreen (EGL)")
    rb.add_argument("--agents", type=_positive(int), action="extend", nargs="+", default=None)
    rb.add_argument("--width", type=_positive(int), default=1280)
    rb.add_argument("--height", type=_positive(int), default=720)
    rb.add_argument("--frames", type=_positive(int), default=30)
    rb.add_argument("--warmup", type=_non_negative, default=3,
                    help="untimed frames first (default: %(default)s)")
    rb.add_argument("--fovy", type=field_of_view, default=70.0,
                    help="vertical field of view in degrees (default: %(default)s, the desktop's; "
                         "a headset's is about 90-110)")
    rb.add_argument("--json", action="store_true")

    from pedvr.study.cli import add_study_parser

    add_study_parser(sub)
    from pedvr.measure.cli import add_measure_parser

    add_measure_parser(sub)
    from pedvr.sweep.cli import add_bench_parser, add_sweep_parser

    add_sweep_parser(sub)
    add_bench_parser(bsub)
    from pedvr.xr.check import add_xr_parser

    add_xr_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        if args.command == "run":
            return _run(args)
        if args.command == "scene":
            return _scene(args)
        if args.command == "prepare":
            return _prepare(args)
        if args.command == "study":
            from pedvr.study.cli import run_study_command

            return run_study_command(args)
        if args.command == "sweep":
            from pedvr.sweep.cli import run_sweep_command

            return run_sweep_command(args)
        if args.command == "measure":
            from pedvr.measure.cli import run_measure_command

            return run_measure_command(args)
        if args.command == "xr":
            from pedvr.xr.check import run_xr_command

            return run_xr_command(args)
        return _bench(args)
    except PedvrError as exc:
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"pedvr: error: {line}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("pedvr: interrupted", file=sys.stderr)
        return 130


def _prepare(args: argparse.Namespace) -> int:
    """``pedvr prepare``: the first steps of each scene on a simulation thrown away after, the first
    scene's kernels compiling beside its set-up in a second process when numba's cache is cold
    (:mod:`pedvr.warmup`, issue 27)."""
    from pedvr import warmup
    from pedvr.prepare import PREPARE_STEPS, first_step, set_up, stderr_say, twin_steps
    from pedvr.scene.loader import load_any
    from pedvr.sim import Simulation

    paths = [resolve_scene(name) for name in args.scenes or [DEFAULT_SCENE]]
    scenes = [load_any(path, seed=None) for path in paths]
    t0 = time.perf_counter()
    compiled = 0
    warmup.start_if_cold(str(paths[0]), args.condition)  # the first scene's kernels; the rest add few
    for scene in scenes:
        stderr_say(f"preparing {scene.name} ({args.condition}) ...")
        sim, n = set_up(functools.partial(Simulation, scene, condition=args.condition), say=stderr_say)
        compiled += n + first_step(sim, say=stderr_say, intro=not n, warmer=warmup.take()).kernels_compiled
        for _ in range(PREPARE_STEPS - 1):  # past the 30 Hz decisions and subconscious actions
            sim.step()
        # a headless run reaches the turned footprints' kernels too (someone squeezing past): always
        compiled += twin_steps(sim, say=stderr_say, twins=args.view)[0]
    if args.view:
        stderr_say("preparing: the procedural character's mesh ...")
        from pedvr.render.bodymesh import procedural_character

        procedural_character()
    stderr_say(f"prepared {', '.join(s.name for s in scenes)} in {time.perf_counter() - t0:.1f} s "
               f"({compiled} kernels compiled); runs now load them from numba's cache")
    return 0


def _interrupted_code(interrupted: object) -> int:
    """A run ended early (its outputs written) exits as the signal that ended it would, 128 + its
    number, as ``pedvr study run`` does: a script that runs ``pedvr run ... && next`` stops
    there. 0 for a run that went its whole duration."""
    if not interrupted:
        return 0
    import signal

    sig = signal.SIGINT if interrupted is True else getattr(signal, str(interrupted), signal.SIGINT)
    return 128 + int(sig)


def _run(args: argparse.Namespace) -> int:
    from pedvr.errors import BackendUnavailableError
    from pedvr.scene.loader import load_any
    from pedvr.xr.select import choose_backend, fallback_after

    files = args.frames is not None or args.video is not None
    _check_outputs(args)
    if files and args.backend in ("xr", "desktop"):
        raise UsageError(f"--frames/--video write files from the headless renderer; drop --backend "
                         f"{args.backend} or use --backend headless")
    if files:
        backend, why = "headless", "backend: headless (rendering offscreen to --frames/--video)"
    else:
        backend, why = choose_backend(args.backend)
    path = resolve_scene(args.scene)
    scene = load_any(path, seed=args.seed)
    print(why)
    from pedvr import warmup
    from pedvr.xr.run import ViewOptions

    warmup.start_if_cold(str(path), args.condition)  # a cold cache: the step's kernels compile meanwhile

    while True:
        desk = backend == "desktop"
        opts = ViewOptions(frames=args.frames, video=args.video, view=args.view,
                           width=args.width or (1280 if desk else 640),
                           height=args.height or (720 if desk else 360),
                           fps=args.fps, label=args.label, vsync=not args.no_vsync)
        common = {"duration": args.duration, "seed": args.seed, "condition": args.condition,
                  "responsibility": args.responsibility, "personal_space": args.personal_space,
                  "user_walk": args.user_walk, "record": args.record,
                  "metrics_json": args.metrics_json, "out": args.out}
        try:
            if backend == "headless":
                from pedvr.headless import run_headless

                summary = run_headless(scene, progress=not args.quiet, view=opts, **common)
            else:
                from pedvr.xr.run import run_with_view

                summary = run_with_view(scene, backend=backend, opts=opts, **common)
            if not summary:
                return 1
            return _interrupted_code(summary.get("interrupted", False))
        except BackendUnavailableError as exc:
            from pedvr.xr.session import BackendLostError

            lost = isinstance(exc, BackendLostError)
            nxt = None if lost or args.backend != "auto" else fallback_after(backend)
            if nxt is None:
                raise
            print(f"backend: {nxt} ({backend} could not start: {exc})")
            backend = nxt


def _writable_folder(path: Path, flag: str) -> None:
    """Create ``path`` (a folder) if needed; one clear line if that cannot be done."""
    if path.exists() and not path.is_dir():
        raise UsageError(f"{flag} {path}: exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{flag} {path}: cannot create the folder ({exc.strerror})") from None
    try:  # os.access says yes to root everywhere, even in /proc: try it
        tempfile.TemporaryFile(dir=path).close()
    except OSError as exc:
        raise UsageError(f"{flag} {path}: the folder is not writable ({exc.strerror})") from None


def _writable_file(path: Path, flag: str) -> None:
    """``path`` can be written: not a folder, in a folder that exists or can be made, writable."""
    if path.is_dir():
        raise UsageError(f"{flag} {path}: is a folder; give a file name")
    _writable_folder(path.parent, flag + " folder")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{flag} {path}: the file exists and is not writable")


def _check_outputs(args: argparse.Namespace) -> None:
    """Every output of ``pedvr run`` can be written, checked before the run starts (a long run
    must not end in a traceback and lose its results)."""
    if args.frames is not None:
        _writable_folder(args.frames, "--frames")
    if args.video is not None:
        _writable_file(args.video, "--video")
    if args.record is None or args.metrics_json is None:
        _writable_folder(args.out, "--out")
    if args.record is not None:
        _writable_file(args.record, "--record")
    if args.metrics_json is not None:
        _writable_file(args.metrics_json, "--metrics-json")


def _scene(args: argparse.Namespace) -> int:
    from pedvr.errors import SceneError
    from pedvr.scene.checks import spawn_warnings
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
        warnings = spawn_warnings(s)
        for line in warnings:
            print(line)
        n = sum(sp.count or len(sp.positions) for sp in s.spawns)
        print(f"{f}: ok: scene {s.name!r}, {_count(n, 'agent')}, "
              f"{_count(len(s.world.obstacles), 'obstacle')}, {_count(len(s.behavior.states), 'state')}"
              + (f"; {_count(len(warnings), 'warning')}" if warnings else ""))
    return status


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _print_results(results: list[dict[str, object]], as_json: bool) -> None:
    if as_json:
        print(json.dumps(results[0] if len(results) == 1 else results, indent=2))
    else:
        for r in results:
            print(", ".join(f"{k}={v}" for k, v in r.items()))


def _bench(args: argparse.Namespace) -> int:
    if args.bench_command == "realism":
        from pedvr.measure.cli import run_realism_command

        return run_realism_command(args)
    if args.bench_command == "sweep":
        from pedvr.sweep.cli import run_bench_command

        return run_bench_command(args)
    if args.bench_command == "render":
        from pedvr.render.bench import run_render_bench

        _print_results([run_render_bench(n, width=args.width, height=args.height, frames=args.frames,
                                         warmup=args.warmup, fovy=args.fovy)
                        for n in args.agents or [100, 500]], args.json)
        return 0
    if args.bench_command == "behavior":
        from pedvr.behavior.bench import run_behavior_bench

        if not 0 <= args.events <= 70:
            raise UsageError(f"--events {args.events}: expected 0 to 70 (conversations that fit the plaza)")
        _print_results([run_behavior_bench(n, events=args.events, seconds=args.seconds)
                        for n in args.agents or [200]], args.json)
        return 0
    if args.bench_command == "place":
        from pedvr.demonstrator.bench import SCENES, run_place_bench

        _print_results([run_place_bench(s, queries=args.queries, seconds=args.seconds)
                        for s in args.scene or SCENES], args.json)
        return 0
    if args.bench_command == "sim":
        from pedvr.bench_sim import run_sim_bench

        _print_results([run_sim_bench(n, steps=args.steps, warmup=args.warmup, load=k, vs=args.vs)
                        for n in args.agents or [100, 1000] for k in args.load or [0]], args.json)
        return 0
    if args.bench_command == "doors":
        from pedvr.etiquette.bench import run_doors_bench

        _print_results([run_doors_bench(n, steps=args.steps, warmup=args.warmup)
                        for n in args.agents or [16, 64]], args.json)
        return 0
    if args.bench_command == "body":
        from pedvr.body.bench import run_body_bench

        _print_results([run_body_bench(n, steps=args.steps) for n in args.agents or [100, 1000]], args.json)
        return 0
    from pedvr.benchload import check_load
    from pedvr.crowd.bench import run_steering_bench

    loads = [check_load(k) for k in args.load or [0]]
    results = []
    for n in args.agents or [1000, 4000]:
        for k in loads:
            kw = {"steps": args.steps} if args.steps else {}
            t0 = time.perf_counter()
            r = run_steering_bench(n, vs_rvo2=args.vs == "rvo2", load=k, **kw)
            r["wall_s"] = round(time.perf_counter() - t0, 3)
            results.append(r)
    _print_results(results, args.json)
    return 0
