"""Choosing the presentation backend: OpenXR, else a desktop window, else headless.

``pedvr run`` says in one line which backend it chose and why. In this
version only the headless backend exists (simulation without rendering);
the OpenXR and desktop backends arrive with the renderer. Asking for one of
them by name is one clear error, never a traceback.
"""

from __future__ import annotations

import importlib.util
import os

from pedvr.errors import BackendUnavailableError, UsageError

BACKENDS = ("auto", "xr", "desktop", "headless")


def _openxr_missing() -> str:
    if importlib.util.find_spec("xr") is None:
        return "pyopenxr is not installed"
    return "the OpenXR backend is not part of this version"


def _display_missing() -> str:
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return "no display (DISPLAY is not set)"
    return "the desktop window is not part of this version"


def choose_backend(requested: str) -> tuple[str, str]:
    """``(backend, one-line reason)``; raises when a forced backend cannot start."""
    if requested not in BACKENDS:
        raise UsageError(f"--backend {requested!r}: expected one of {', '.join(BACKENDS)}")
    if requested == "xr":
        raise BackendUnavailableError(
            f"cannot start the OpenXR backend: {_openxr_missing()}; use --backend headless")
    if requested == "desktop":
        raise BackendUnavailableError(
            f"cannot open a desktop window: {_display_missing()}; use --backend headless")
    if requested == "headless":
        return "headless", "backend: headless (asked for with --backend headless)"
    return "headless", (f"backend: headless (no OpenXR: {_openxr_missing()}; "
                        f"no desktop: {_display_missing()})")
