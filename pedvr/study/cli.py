"""``pedvr study run | export | analyze``.

``pedvr study run PROTOCOL --participant P07 [--backend auto|xr|desktop|headless] [--resume]``
``pedvr study run PROTOCOL --participant simulated [--max-trial-seconds S]``   (a scripted dry run)
``pedvr study export DB --out DIR [--force]``
``pedvr study analyze (DB | --responses FILE.csv) [--json] [--report DIR]``

``pedvr/cli.py`` wires these in with :func:`add_study_parser` and
:func:`run_study_command`; ``python -m pedvr.study ...`` runs them on their
own (:func:`main`). Errors print as ``pedvr: error: ...`` lines with a
non-zero exit code, never a traceback. A session ended by SIGTERM or SIGHUP
is recorded as aborted (:mod:`pedvr.signals`), says so in one line and
exits with 128 + the signal's number.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import Any, TextIO

from pedvr.argtypes import positive
from pedvr.errors import PedvrError, UsageError
from pedvr.scene.config import USER_WALKS

EXIT_ABORTED = 4


class _StudyParser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{self.prog}: {message}")


def _add_commands(study: argparse.ArgumentParser) -> None:
    sub = study.add_subparsers(dest="study_command", required=True, parser_class=type(study))
    run = sub.add_parser("run", help="run (or resume) one participant through a protocol")
    run.add_argument("protocol", type=Path, help="protocol file, e.g. user_study/pedvr_replication.toml")
    run.add_argument(
        "--participant",
        required=True,
        help="participant id ending in a number (P07), or 'simulated' for a scripted dry run",
    )
    run.add_argument("--backend", default="auto", choices=("auto", "xr", "desktop", "headless"))
    run.add_argument(
        "--resume", action="store_true", help="continue an existing participant at the first unfinished step"
    )
    run.add_argument(
        "--simulated",
        action="store_true",
        help="the named participant is scripted (follows the spheres, seeded answers)",
    )
    run.add_argument("--db", type=Path, default=None, help="study database (default: ./<study name>.sqlite)")
    run.add_argument(
        "--max-trial-seconds",
        type=positive(float),
        default=None,
        help="cap every trial's time limit (dry runs)",
    )
    run.add_argument(
        "--pace",
        type=positive(float),
        default=None,
        help="simulated participant only: run trials at this multiple of real time",
    )
    run.add_argument(
        "--walk",
        choices=USER_WALKS,
        default=None,
        help="simulated participant only: step aside for pedestrians like a person (reactive, the "
        "default) or walk the route straight",
    )

    export = sub.add_parser("export", help="export a study database as TSV/CSV files")
    export.add_argument("db", type=Path)
    export.add_argument("--out", type=Path, required=True, help="output folder")
    export.add_argument("--force", action="store_true", help="overwrite files the export would write")

    an = sub.add_parser("analyze", help="analyse the pairwise questionnaire (PedVR §6.5), SSQ and corridor")
    an.add_argument("db", type=Path, nargs="?", default=None, help="study database")
    an.add_argument(
        "--responses",
        type=Path,
        default=None,
        help="long-format CSV: participant,scenario,comparison,question,response",
    )
    an.add_argument("--json", action="store_true", help="print the results as JSON")
    an.add_argument(
        "--report", type=Path, default=None, help="write report.html, report.md and SVG figures into a folder"
    )


def add_study_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Add ``study`` with its ``run``, ``export`` and ``analyze`` subcommands to ``subparsers``."""
    study = subparsers.add_parser("study", help="run, export and analyse user studies")
    _add_commands(study)
    return study


def build_parser() -> argparse.ArgumentParser:
    """A stand-alone parser for ``python -m pedvr.study``."""
    p = _StudyParser(prog="pedvr study", description="Run, export and analyse pedvr user studies.")
    _add_commands(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
        return run_study_command(args)
    except PedvrError as exc:
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"pedvr: error: {line}", file=sys.stderr)
        return exc.exit_code
    except KeyboardInterrupt:
        print("pedvr: interrupted; continue with --resume", file=sys.stderr)
        return 130


def run_study_command(
    args: argparse.Namespace, *, stdin: TextIO | None = None, stdout: TextIO | None = None
) -> int:
    """Run a parsed ``study`` command; return the exit code. Raises :class:`PedvrError` on bad input."""
    from pedvr.study.errors import damage_reported

    out = stdout or sys.stdout
    if args.study_command == "run":
        return _run(args, stdin=stdin or sys.stdin, stdout=out)
    if args.study_command == "export":
        from pedvr.study.export import export_study

        with damage_reported(args.db):
            paths = export_study(args.db, out=args.out, force=args.force)
        print(f"exported {len(paths)} files to {args.out}", file=out)
        return 0
    if args.db is None:
        return _analyze(args, stdout=out)
    with damage_reported(args.db):
        return _analyze(args, stdout=out)


def _run(args: argparse.Namespace, *, stdin: TextIO, stdout: TextIO) -> int:
    from pedvr.study.errors import damage_reported
    from pedvr.study.protocol import load_protocol, participant_number
    from pedvr.study.store import StudyStore

    simulated = args.simulated or args.participant == "simulated"
    if args.participant != "simulated":
        participant_number(args.participant)  # a bad id is refused before any file is created
    if args.pace is not None and not simulated:
        raise UsageError("--pace applies only to a simulated participant")
    if args.walk is not None and not simulated:
        raise UsageError("--walk applies only to a simulated participant")
    protocol = load_protocol(args.protocol)
    db = args.db or Path(f"{protocol.name}.sqlite")
    if args.resume and not db.is_file():
        raise UsageError(
            f"--resume: {db}: no such study database (nothing was created); give the database the "
            "participant "
            "started in with --db, or run from the folder that holds it"
        )
    if db.is_file():  # a damaged database is refused before anything is written to it
        with StudyStore(db, read_only=True) as existing:
            existing.check_intact()
    backend, why = _study_backend(args.backend, simulated=simulated)
    print(why, file=stdout)
    frontend = None
    if backend in ("xr", "desktop"):
        from pedvr.xr.participant import open_frontend, prepare_protocol

        prepare_protocol(protocol)  # before the view opens: compiling in a running headset freezes it
        frontend = open_frontend(backend, eye_height=protocol.eye_height_m)
    try:
        with damage_reported(db):
            return _run_in(
                args, protocol, db, backend, frontend, simulated=simulated, stdin=stdin, stdout=stdout
            )
    finally:
        if frontend is not None:
            frontend.close()


def _run_in(
    args: argparse.Namespace,
    protocol: Any,
    db: Path,
    backend: str,
    frontend: Any,
    *,
    simulated: bool,
    stdin: TextIO,
    stdout: TextIO,
) -> int:
    from pedvr.signals import TerminatedBySignal, calls_restart, signals_abort
    from pedvr.study.console import ExperimenterConsole, KeySource, NoKeys, TerminalKeys
    from pedvr.study.presenter import Participant, SimulatedParticipant, TerminalParticipant
    from pedvr.study.protocol import participant_number
    from pedvr.study.session import Session
    from pedvr.study.store import StudyStore

    with StudyStore(db) as store:
        pid = args.participant
        if pid == "simulated":
            if args.resume:
                raise UsageError(
                    "--resume needs the simulated participant's id (e.g. --participant SIM03 --simulated)"
                )
            pid = f"SIM{store.next_number():02d}"
        number = participant_number(pid)
        keys: KeySource = TerminalKeys(stdin, stdout) if _isatty(stdin) else NoKeys()
        console = ExperimenterConsole(out=stdout, keys=keys)
        participant: Participant
        if frontend is not None:
            from pedvr.xr.participant import InAppParticipant

            participant = InAppParticipant(frontend, console=console)
        elif simulated:
            participant = SimulatedParticipant(
                seed=protocol.seed, number=number, eye_height_m=protocol.eye_height_m, pace=args.pace or 0.0,
                walk=args.walk or "reactive",
            )
        else:
            participant = TerminalParticipant(stdin=stdin, stdout=stdout, eye_height_m=protocol.eye_height_m)
        session = Session(
            protocol=protocol,
            store=store,
            participant_id=pid,
            participant=participant,
            console=console,
            backend=backend,
            resume=args.resume,
            max_trial_s=args.max_trial_seconds,
            simulated=simulated,
        )
        try:
            # xr: a signal never fails an OpenXR call in progress (pedvr.signals.calls_restart)
            with signals_abort(), (calls_restart() if backend == "xr" else nullcontext()):
                result = session.run()
        except TerminatedBySignal as exc:
            print(
                f"pedvr: {exc.name}: session of {pid} aborted and saved in {db}; continue with --resume",
                file=sys.stderr,
            )
            return exc.exit_code
        if result.status == "already_finished":
            print(result.message, file=stdout)
        print(f"database: {db}", file=stdout)
    return EXIT_ABORTED if result.status == "aborted" else 0


def _study_backend(requested: str, *, simulated: bool) -> tuple[str, str]:
    """The backend a study session runs on, and the one line that says why.

    ``xr`` and ``desktop`` run the in-app participant (:mod:`pedvr.xr.participant`:
    questionnaires drawn in the view, answered with controller, keyboard or mouse);
    a backend asked for by name that cannot start is one clear error. ``auto``
    picks xr, else desktop, else headless for a person, and always headless for a
    simulated participant (it needs no view).
    """
    from pedvr.xr.select import choose_backend

    if simulated:
        if requested in ("xr", "desktop"):
            raise UsageError(
                f"--backend {requested}: a simulated participant runs headless (it needs no view); "
                "use --backend headless or auto"
            )
        return "headless", (
            "backend: headless (a simulated participant)"
            if requested == "auto"
            else "backend: headless (asked for with --backend headless)"
        )
    return choose_backend(requested)


def _isatty(f: TextIO) -> bool:
    try:
        return f.isatty()
    except (AttributeError, ValueError):
        return False


def _analyze(args: argparse.Namespace, *, stdout: TextIO) -> int:
    from pedvr.study.analysis import analyze, apa_friedman, apa_rm_anova, apa_t

    if (args.db is None) == (args.responses is None):
        raise UsageError("pedvr study analyze: give a study database or --responses FILE.csv (exactly one)")
    result = analyze(db=args.db, responses=args.responses)
    if args.report is not None:
        from pedvr.study.report import write_report

        page = write_report(result, out=args.report)
        if not args.json:
            print(f"report: {page} (and {page.with_suffix('.md').name})", file=stdout)
    if args.json:
        json.dump(result, stdout, indent=2, sort_keys=False, default=str)
        stdout.write("\n")
        return 0
    print(f"{result['n_participants']} participants, {result['n_responses']} pairwise responses", file=stdout)
    _print_other_sections(result, stdout)
    for scen, s in result["scenarios"].items():
        print(f"{scen}:", file=stdout)
        for c, v in s["comparisons"].items():
            t = v["one_sample_t_vs_4"]
            alpha = "–" if v["cronbach_alpha"] is None else f"{v['cronbach_alpha']:.2f}"
            sd = "–" if v["sd"] is None else f"{v['sd']:.2f}"
            print(
                f"  {c}: n = {v['n']}, M = {v['mean']:.2f}, SD = {sd}, α = {alpha}, "
                f"<4 {v['pct_less_than_4']:.1f}%, =1 {v['pct_equal_1']:.1f}%, =4 {v['pct_equal_4']:.1f}%"
                + (f"; vs 4: {apa_t(t)}" if t else ""),
                file=stdout,
            )
        if s.get("rm_anova"):
            print(f"  RM-ANOVA: {apa_rm_anova(s['rm_anova'])}", file=stdout)
            for ph in s["posthoc_bonferroni"]:
                print(
                    f"  post hoc {ph['a']} vs {ph['b']}: p(Bonferroni) = {ph['p_bonferroni']:.3f}",
                    file=stdout,
                )
        if s.get("friedman"):
            print(f"  Friedman: {apa_friedman(s['friedman'])}", file=stdout)
    return 0


def _print_other_sections(result: dict[str, Any], stdout: TextIO) -> None:
    """One line each for the sections of a database analysis besides the pairwise questionnaire."""
    from pedvr.study.analysis import apa_rm_anova

    ssq = result.get("ssq") or {}
    if ssq.get("summary"):
        s = ssq["summary"]
        line = "SSQ total: " + ", ".join(
            f"{phase} M = {s[phase]['total']['mean']:.2f} (n = {s[phase]['total']['n']})"
            for phase in ("before", "after", "change")
            if phase in s
        )
        w = (ssq.get("tests") or {}).get("total", {}).get("wilcoxon")
        if w:
            line += f"; Wilcoxon W = {w['W']:.2f}, p = {w['p']:.3f}"
        print(line, file=stdout)
    for qid, blocks in (result.get("questionnaires") or {}).get("by_block", {}).items():
        for block, b in blocks.items():
            for name, res in b["scores"].items():
                means = ", ".join(
                    f"{lv} {d['mean']:.2f}" for lv, d in res["levels"].items() if d["mean"] is not None
                )
                test = apa_rm_anova(res["rm_anova"]) if res.get("rm_anova") else res.get("note", "")
                print(f"{qid} {name} in {block}: {means}; {test}", file=stdout)
    for qid, scores in (result.get("questionnaires") or {}).get("once", {}).items():
        for name, d in scores.items():
            if d["mean"] is not None:
                print(f"{qid} {name}: M = {d['mean']:.2f} (n = {d['n']})", file=stdout)
    for block, b in (result.get("measures") or {}).get("by_block", {}).items():
        for name, res in b["measures"].items():
            means = ", ".join(
                f"{lv} {d['mean']:.3f}" for lv, d in res["levels"].items() if d["mean"] is not None
            )
            test = apa_rm_anova(res["rm_anova"]) if res.get("rm_anova") else res.get("note", "")
            print(f"{block} {name}: {means}; {test}", file=stdout)
