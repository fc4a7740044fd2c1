"""No OpenXR runtime, for real: this is what CI machines have (XR_ERROR_RUNTIME_UNAVAILABLE)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from pedvr.errors import BackendUnavailableError

pytest.importorskip("xr")
if os.environ.get("XR_RUNTIME_JSON"):
    pytest.skip(
        "an OpenXR runtime is configured (XR_RUNTIME_JSON): the no-runtime tests do not apply",
        allow_module_level=True,
    )


def test_the_real_loader_says_no_runtime_in_one_line() -> None:
    from pedvr.xr.openxr import NO_RUNTIME, probe_openxr

    why = probe_openxr()
    assert why == NO_RUNTIME
    assert "\n" not in why


def test_opening_the_real_port_fails_with_one_clear_line() -> None:
    from pedvr.xr.openxr import OpenXRPort

    with pytest.raises(BackendUnavailableError) as err:
        OpenXRPort.open()
    msg = str(err.value)
    assert msg.startswith("cannot start the OpenXR backend: no OpenXR runtime is active") and "\n" not in msg
    assert "--backend desktop or --backend headless" in msg


def test_forced_xr_is_one_line_and_no_loader_noise_and_auto_falls_back(tmp_path: object) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "XR_LOADER_DEBUG")}
    r = subprocess.run(
        [sys.executable, "-m", "pedvr", "run", "headon_corridor", "--backend", "xr"],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert r.returncode == 3
    assert r.stderr.strip().splitlines() == [
        "pedvr: error: cannot start the OpenXR backend: no OpenXR runtime is active (the loader found none: "
        "start SteamVR, Monado or Meta Quest Link, or set XR_RUNTIME_JSON); use --backend headless "
        "(or --backend desktop)"
    ]
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "pedvr",
            "run",
            "headon_corridor",
            "--duration",
            "0.2",
            "--quiet",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
        env=env,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0].startswith("backend: headless (no OpenXR: no OpenXR runtime is active")
    assert "OpenXR-Loader" not in r.stderr
