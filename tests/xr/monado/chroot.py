"""A real OpenXR runtime for the tests: Monado 25 in the Debian trixie chroot that ``.ci/monado-chroot``
builds (issue 23).

:class:`Chroot` runs commands inside it with a clean environment; :class:`Xvfb`
is an X server started inside it (Monado's real compositor and its debug window
need one; pedvr's EGL context does not); :class:`Service` is ``monado-service``
with the simulated HMD (wobbling slightly, as the driver does) or the qwerty
devices (a still HMD at 1.6 m; its controllers take xdotool's keys and clicks
in the service's debug window), on the null compositor or the real one on
Xvfb. Files pass through a folder inside the chroot, which the host reads
through the chroot's root.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
ROOT = Path(os.environ.get("PEDVR_MONADO_ROOT", "/var/cache/pedvr/trixie"))
SCRIPT = REPO / ".ci" / "monado-chroot"
RUNTIME_DIR = "/run/pedvr-xr"  # each service gets a folder of its own below this
RUNTIME_JSON = "/usr/share/openxr/1/openxr_monado.json"
PEDVR = "/opt/pedvr-venv/bin/pedvr"
PYTHON = "/opt/pedvr-venv/bin/python"
BUILD = "sudo .ci/monado-chroot build (a few minutes and about 4.5 GiB, once; PEDVR_MONADO_ROOT puts it elsewhere)"


def unavailable() -> str | None:
    """None when the chroot can run the tests here; else one line saying why and how to make it."""
    if os.geteuid() != 0:
        return f"the Monado tests need root (chroot, mount); run them as root after {BUILD}"
    if not (ROOT / ".pedvr-chroot-ready").is_file() or not (ROOT / PEDVR.lstrip("/")).is_file():
        return f"no Monado chroot at {ROOT}: make it with {BUILD}"
    if not shutil.which("chroot"):
        return "chroot(8) is not on PATH"
    return None


class Chroot:
    """Commands inside the chroot (this checkout bound at /pedvr, installed editable there)."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root

    def mount(self) -> None:
        r = subprocess.run([str(SCRIPT), "mount"], env={**os.environ, "PEDVR_MONADO_ROOT": str(self.root)},
                           capture_output=True, text=True, timeout=60)
        if r.returncode != 0:
            raise RuntimeError(f".ci/monado-chroot mount failed: {r.stderr.strip()}")

    def host(self, path: str) -> Path:
        """The host path of ``path`` inside the chroot."""
        return self.root / path.lstrip("/")

    def argv(self, args: list[str], env: dict[str, str]) -> list[str]:
        base = {"HOME": "/root", "PATH": "/usr/local/bin:/usr/bin:/bin", "LANG": "C.UTF-8"}
        return ["chroot", str(self.root), "/usr/bin/env", "-i",
                *(f"{k}={v}" for k, v in {**base, **env}.items()), *args]

    def popen(self, args: list[str], *, env: dict[str, str], **kw: object) -> subprocess.Popen[str]:
        return subprocess.Popen(self.argv(args, env), text=True, **kw)  # type: ignore[call-overload]

    def run(self, args: list[str], *, env: dict[str, str], timeout: float,
            **kw: object) -> subprocess.CompletedProcess[str]:
        return subprocess.run(self.argv(args, env), text=True, capture_output=True, timeout=timeout,
                              **kw)  # type: ignore[call-overload]


class Xvfb:
    """An X server inside the chroot; :attr:`display` is its ``:N``."""

    def __init__(self, chroot: Chroot, *, size: str = "1280x1024x24") -> None:
        read, write = os.pipe()
        self.proc = subprocess.Popen(
            chroot.argv(["Xvfb", "-displayfd", str(write), "-screen", "0", size, "-nolisten", "tcp"], {}),
            pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        os.close(write)
        with os.fdopen(read) as f:
            number = f.readline().strip()
        if not number:
            self.proc.kill()
            raise RuntimeError("Xvfb did not start inside the chroot")
        self.display = f":{number}"

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Service:
    """``monado-service`` inside the chroot. ``devices``: ``simulated`` (HMD + two WMR controllers,
    which cannot be moved or pressed) or ``qwerty`` (a still HMD; it and its WMR controllers driven
    by keys and clicks in Monado's debug window on ``display``). ``compositor``: ``null`` (no
    output; eyes 320x240) or ``xcb`` (Monado's real compositor in a window on ``display``: eyes
    896x1007, as Monado sizes them for its simulated display)."""

    _count = 0

    def __init__(self, chroot: Chroot, *, log: Path, devices: str = "simulated", compositor: str = "null",
                 display: str | None = None, env: dict[str, str] | None = None) -> None:
        self.chroot = chroot
        self.log = log
        Service._count += 1
        self.runtime_dir = f"{RUNTIME_DIR}/{os.getpid()}-{Service._count}"  # services never share a socket
        sock = chroot.host(f"{self.runtime_dir}/monado_comp_ipc")
        sock.parent.mkdir(parents=True, exist_ok=True)
        sock.unlink(missing_ok=True)  # a stale socket from a killed service
        e = {"XDG_RUNTIME_DIR": self.runtime_dir, "XRT_NO_STDIN": "1"}
        if devices == "simulated":
            e.update(SIMULATED_ENABLE="1", SIMULATED_LEFT="wmr", SIMULATED_RIGHT="wmr")
        elif devices == "qwerty":
            e.update(QWERTY_ENABLE="1", XRT_DEBUG_GUI="1")
        else:
            raise ValueError(devices)
        if compositor == "null":
            e["XRT_COMPOSITOR_NULL"] = "1"
        elif compositor == "xcb":
            e["XRT_COMPOSITOR_FORCE_XCB"] = "1"
        else:
            raise ValueError(compositor)
        if compositor == "xcb" or devices == "qwerty":
            assert display is not None, f"{compositor} compositor / {devices} devices need a display"
            e["DISPLAY"] = display
        e.update(env or {})
        # One service at a time on this machine, whichever pytest-xdist worker starts it (the
        # Monado tests are shared out as two units: tests/conftest.py): held until stop().
        lock = chroot.host(f"{RUNTIME_DIR}/service.lock")
        lock.parent.mkdir(parents=True, exist_ok=True)
        self._lock = lock.open("a")
        fcntl.flock(self._lock, fcntl.LOCK_EX)
        self._out = log.open("w")
        self.proc = chroot.popen(["monado-service"], env=e, stdout=self._out, stderr=subprocess.STDOUT,
                                 start_new_session=True)
        deadline = time.monotonic() + 60
        while not sock.exists():
            if self.proc.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"monado-service did not start; its log: {log}")
            time.sleep(0.1)

    def client_env(self, **extra: str) -> dict[str, str]:
        """The environment of an OpenXR client of this service (Monado's own prints kept quiet)."""
        return {"XDG_RUNTIME_DIR": self.runtime_dir, "XR_RUNTIME_JSON": RUNTIME_JSON, "OXR_NO_PRINTING": "1",
                "XRT_LOG": "error", **extra}

    def text(self) -> str:
        if not self._out.closed:
            self._out.flush()
        return self.log.read_text(errors="replace")

    def kill(self) -> None:
        """SIGKILL, as a crash would."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(10)

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(3)  # with its debug window (qwerty) Monado may not leave on SIGTERM
            except subprocess.TimeoutExpired:
                self.kill()
        self._out.close()
        if not self._lock.closed:
            self._lock.close()  # and with it the lock
