"""``pedvr xr check``: what a lab needs to know about its OpenXR runtime and headset, in one command.

It starts a real session (the same OpenXR port as ``pedvr run --backend xr``),
submits empty frames until the runtime says FOCUSED and the controllers'
interaction profiles are bound (or ``timeout`` seconds pass), reads the
runtime's facts (:meth:`pedvr.xr.openxr.OpenXRPort.runtime_facts`), ends the
session and prints them: the runtime's name and version, the system, the view
configuration and the recommended resolution per eye, the display's refresh
rates where the runtime says, the reference spaces and play-area bounds, the
interaction profile bound to each hand, and whether eye-gaze interaction is
offered. A study session stores the same facts with its records
(:class:`pedvr.xr.participant.InAppParticipant`).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

from pedvr.errors import BackendUnavailableError


def focused_facts(port: Any, *, timeout: float = 15.0,
                  clock: Callable[[], float] = time.monotonic) -> dict[str, Any]:
    """Run ``port``'s session until focused (empty frames), read its facts, end the session.

    ``focused`` in the answer says whether the runtime reached FOCUSED within ``timeout`` s (without
    it the interaction profiles cannot be bound). Raises BackendUnavailableError (one line) when the
    runtime goes away meanwhile."""
    # Imported here, not at the top: `pedvr --help` and `pedvr scene check` build this command's parser
    # and must not pull in the session logic and the renderer's maths behind it.
    from pedvr.xr.session import FACTS_AFTER_FRAMES, RuntimeLostError, SessionLogic

    logic = SessionLogic(port)
    deadline = clock() + timeout
    focused_frames = 0
    try:
        while clock() < deadline and focused_frames < FACTS_AFTER_FRAMES:  # synced frames, then profiles
            for ev in port.poll_events():
                logic.handle(ev)
            if logic.done:
                break
            if not logic.running:
                port.idle_wait()
                continue
            port.wait_frame()
            port.begin_frame()
            port.sync_controls(focused=logic.focused)
            port.end_frame(display_time=0.0, views=None)
            focused_frames += int(logic.focused)
        facts = port.runtime_facts()
        facts["focused"] = focused_frames > 0
        logic.request_exit()
        end = clock() + 5.0
        while not logic.done and clock() < end:  # on to EXITING, submitting frames while running
            for ev in port.poll_events():
                logic.handle(ev)
            if logic.running:
                port.wait_frame()
                port.begin_frame()
                port.end_frame(display_time=0.0, views=None)
            elif not logic.done:
                port.idle_wait()
    except RuntimeLostError as exc:
        raise BackendUnavailableError(f"xr check: {exc}") from None
    facts["session_states"] = [s.name for s in logic.history]
    if logic.lost:
        raise BackendUnavailableError(f"xr check: {logic.lost}")
    return facts


def facts_lines(f: dict[str, Any]) -> list[str]:
    """The facts as the lines ``pedvr xr check`` prints."""
    sizes = {tuple(s) for s in f["recommended_eye_size"]}
    size = " and ".join(f"{w}x{h}" for w, h in sorted(sizes))
    tracking = [k for k in ("orientation", "position") if f[f"{k}_tracking"]]
    rates = f.get("refresh_rates_hz")
    hands = f.get("interaction_profiles") or {}
    eye = f["eye_gaze_interaction"]
    gfx = f["graphics"]
    area = f.get("play_area_m")
    return [
        f"runtime: {f['runtime']} (version {f['runtime_version']})",
        f"system: {f['system']} (vendor id {f['vendor_id']}), tracking: {' and '.join(tracking) or 'none'}",
        f"view configuration: {f['view_configuration']}, {len(f['recommended_eye_size'])} views, "
        f"recommended {size} pixels per eye",
        "refresh rate: " + (
            f"{f['refresh_hz']:g} Hz (offered: {', '.join(f'{r:g}' for r in rates)} Hz)"
            if f.get("refresh_hz") and rates else "the runtime does not say (no XR_FB_display_refresh_rate)"
        ),
        f"reference spaces: {', '.join(f['reference_spaces'])}; pedvr uses {f['space']}",
        "play area: " + (f"{area[0]:g} x {area[1]:g} m (STAGE bounds)" if area
                         else "the runtime reports no bounds"),
        "interaction profiles: " + (
            ", ".join(f"{hand} {hands.get(hand) or 'none bound'}" for hand in ("left", "right"))
            if f.get("focused") else "not known: the session never became focused"
        ),
        "eye-gaze interaction: " + (
            ("offered (XR_EXT_eye_gaze_interaction), " + ("supported" if eye["supported"] else
                                                         "not supported by this system"))
            if eye["offered"] else "not offered"
        ),
        f"graphics: OpenGL through {gfx['context']}, {gfx['renderer']}, "
        f"{'sRGB' if gfx['srgb_swapchains'] else 'linear'} swapchains",
        "session: " + " -> ".join(f.get("session_states", [])),
    ]


def run_check(*, as_json: bool, timeout: float, out: Callable[[str], None] = print) -> int:
    """``pedvr xr check``: 0 when the session became focused, 3 (with the facts) when it did not."""
    from pedvr.xr.openxr import OpenXRPort

    try:
        port = OpenXRPort.open()
    except BackendUnavailableError as exc:  # the run's advice (other backends) does not apply here
        why = str(exc).removeprefix("cannot start the OpenXR backend: ")
        why = why.removesuffix("; use --backend desktop or --backend headless")
        raise BackendUnavailableError(f"xr check: {why}") from None
    try:
        facts = focused_facts(port, timeout=timeout)
    finally:
        port.close()
    if as_json:
        out(json.dumps(facts, indent=2))
    else:
        for line in facts_lines(facts):
            out(line)
    if not facts["focused"]:
        raise BackendUnavailableError(
            f"xr check: the session did not become focused within {timeout:g} s (put the headset on, "
            "or close the runtime's other application); the facts above are those known without it"
        )
    return 0


def add_xr_parser(sub: Any) -> None:
    """``pedvr xr check`` on the command line's subparsers (:mod:`pedvr.cli`)."""
    xr = sub.add_parser("xr", help="the OpenXR runtime and headset (check)")
    xsub = xr.add_subparsers(dest="xr_command", required=True, parser_class=type(xr), metavar="ACTION")
    check = xsub.add_parser(
        "check", help="the runtime, headset, resolution, refresh rates, spaces, play area, controllers",
        description="Start an OpenXR session, wait until it is focused, and print the runtime's name "
                    "and version, the headset, the recommended resolution per eye, refresh rates, "
                    "reference spaces and play area, each hand's bound interaction profile, and "
                    "whether eye-gaze interaction is offered. Exit 3 with one line when no runtime "
                    "or headset answers.",
    )
    check.add_argument("--json", action="store_true", help="the facts as JSON")
    check.add_argument("--timeout", type=float, default=15.0, metavar="S",
                       help="seconds to wait for the session to become focused")


def run_xr_command(args: Any) -> int:
    if args.timeout <= 0:
        from pedvr.errors import UsageError

        raise UsageError(f"xr check: --timeout {args.timeout:g}: must be > 0")
    return run_check(as_json=args.json, timeout=args.timeout)
