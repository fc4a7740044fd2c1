"""Choosing the presentation backend: OpenXR, else a desktop window, else headless.

``pedvr run`` says in one line which backend it chose and why. The OpenXR
probe is real: it creates an OpenXR instance and asks for a head-mounted
display (on a machine without a runtime the loader answers
``XR_ERROR_RUNTIME_UNAVAILABLE``, which becomes one line); the desktop probe
initialises glfw against ``$DISPLAY``. A backend asked for by name that
cannot start is one clear error naming the cause and what to do, never a
traceback.
"""

from __future__ import annotations

from pedvr.errors import BackendUnavailableError, UsageError

BACKENDS = ("auto", "xr", "desktop", "headless")


def openxr_missing() -> str | None:
    """None when an OpenXR runtime with a headset answers; else why not (one line)."""
    from pedvr.xr.openxr import probe_openxr

    return probe_openxr()


def display_missing() -> str | None:
    """None when a desktop window can be opened; else why not (one line)."""
    from pedvr.xr.desktop import display_missing as probe

    return probe()


def choose_backend(requested: str) -> tuple[str, str]:
    """``(backend, one-line reason)``; raises when a forced backend cannot start."""
    if requested not in BACKENDS:
        raise UsageError(f"--backend {requested!r}: expected one of {', '.join(BACKENDS)}")
    if requested == "headless":
        return "headless", "backend: headless (asked for with --backend headless)"
    if requested == "xr":
        why = openxr_missing()
        if why is not None:
            raise BackendUnavailableError(
                f"cannot start the OpenXR backend: {why}; use --backend headless (or --backend desktop)"
            )
        return "xr", "backend: xr (asked for with --backend xr; an OpenXR runtime and headset answered)"
    if requested == "desktop":
        why = display_missing()
        if why is not None:
            raise BackendUnavailableError(f"cannot open a desktop window: {why}; use --backend headless")
        return "desktop", "backend: desktop (asked for with --backend desktop)"
    xr_why = openxr_missing()
    if xr_why is None:
        return "xr", "backend: xr (an OpenXR runtime and headset answered)"
    desk_why = display_missing()
    if desk_why is None:
        return "desktop", f"backend: desktop (no OpenXR: {xr_why}; a display is available)"
    return "headless", f"backend: headless (no OpenXR: {xr_why}; no desktop: {desk_why})"


def fallback_after(backend: str) -> str | None:
    """The next backend to try in auto mode when ``backend`` fails to start (xr -> desktop -> headless)."""
    if backend == "xr":
        return "desktop" if display_missing() is None else "headless"
    if backend == "desktop":
        return "headless"
    return None
