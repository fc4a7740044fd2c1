"""Fixtures for the tests against Monado (the ``monado`` marker; see :mod:`tests.xr.monado.chroot`).

Every test here is marked ``monado``. Where the chroot is missing (or the tests
do not run as root), none of them is collected and the run's summary says why
in one line; the rest of the suite runs with its fakes.

pedvr runs inside the chroot (``/opt/pedvr-venv/bin/pedvr``, this checkout
installed editable), against a ``monado-service`` each test starts and stops
(so a test can kill it). numba's cache for these runs is one folder inside the
chroot, kept between runs; the cold-start test fills it when it is empty, so
CI compiles once.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.xr.monado.chroot import PEDVR, Chroot, Service, Xvfb, unavailable

WHY = unavailable()
WORK = "/var/tmp/pedvr-monado"  # inside the chroot
NUMBA_CACHE = f"{WORK}/numba-cache"  # kept between runs (the cold test uses its own)


# Without the chroot the modules here are not collected, and the run's summary says why in one line
# (skipping each test instead prints a line per test function in -ra's summary).
collect_ignore_glob = ["test_*.py"] if WHY else []


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    if WHY:
        terminalreporter.write_line(f"SKIPPED tests/xr/monado (the monado tests): {WHY}", yellow=True)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    here = Path(__file__).parent
    for item in items:
        if here in Path(str(item.fspath)).parents:
            item.add_marker(pytest.mark.monado)


@pytest.fixture(scope="session")
def chroot() -> Chroot:
    c = Chroot()
    c.mount()
    c.host(NUMBA_CACHE).mkdir(parents=True, exist_ok=True)
    return c


@pytest.fixture(scope="session")
def xvfb(chroot: Chroot) -> Iterator[Xvfb]:
    x = Xvfb(chroot)
    yield x
    x.stop()


@dataclass
class Run:
    """A finished ``pedvr`` command inside the chroot, its outputs read back through the host."""

    proc: subprocess.CompletedProcess[str]
    out: Path  # host path of the run's --out folder
    chroot_out: str

    @property
    def metrics(self) -> dict:  # type: ignore[type-arg]
        files = sorted(self.out.glob("*.json"))
        assert files, f"no metrics JSON in {self.out}; stderr:\n{self.proc.stderr}"
        return json.loads(files[0].read_text())


class Workspace:
    """Folders for one test inside the chroot (``WORK/<test>``), and pedvr commands run there."""

    def __init__(self, chroot: Chroot, name: str) -> None:
        self.chroot = chroot
        self.path = f"{WORK}/{name}"
        host = chroot.host(self.path)
        shutil.rmtree(host, ignore_errors=True)
        host.mkdir(parents=True)
        self.host = host

    def env(self, service: Service, **extra: str) -> dict[str, str]:
        return service.client_env(**{"NUMBA_CACHE_DIR": NUMBA_CACHE, "PYTHONUNBUFFERED": "1", **extra})

    def pedvr(self, service: Service, args: list[str], *, timeout: float = 600, name: str = "out",
              **env: str) -> Run:
        out = f"{self.path}/{name}"
        t0 = time.monotonic()
        proc = self.chroot.run([PEDVR, *args, "--out", out] if args[0] == "run" else [PEDVR, *args],
                               env=self.env(service, **env), timeout=timeout)
        print(f"pedvr {' '.join(args)}: exit {proc.returncode} in {time.monotonic() - t0:.1f} s")
        return Run(proc, self.chroot.host(out), out)

    def spawn(self, service: Service, args: list[str], *, name: str = "out",
              **env: str) -> tuple[subprocess.Popen[str], Path]:
        """Start ``pedvr`` in the background (stdout and stderr piped); return it and its out folder."""
        out = f"{self.path}/{name}"
        argv = [PEDVR, *args, "--out", out] if args[0] == "run" else [PEDVR, *args]
        proc = self.chroot.popen(argv, env=self.env(service, **env), stdout=subprocess.PIPE,
                                 stderr=subprocess.PIPE)
        return proc, self.chroot.host(out)


@pytest.fixture
def work(chroot: Chroot, request: pytest.FixtureRequest) -> Workspace:
    return Workspace(chroot, request.node.name.replace("[", "-").replace("]", ""))


@pytest.fixture
def service(chroot: Chroot, work: Workspace) -> Iterator[Service]:
    """monado-service with the simulated HMD and WMR controllers on the null compositor."""
    s = Service(chroot, log=work.host / "monado.log")
    yield s
    s.stop()


def wait_for(proc: subprocess.Popen[str], stream_text: list[str], needle: str, timeout: float) -> None:
    """Read ``proc``'s stderr line by line into ``stream_text`` until a line holds ``needle``."""
    assert proc.stderr is not None
    deadline = time.monotonic() + timeout
    os.set_blocking(proc.stderr.fileno(), False)
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if line:
            stream_text.append(line)
            if needle in line:
                return
        elif proc.poll() is not None:
            raise AssertionError(f"pedvr ended (exit {proc.returncode}) before '{needle}':\n"
                                 + "".join(stream_text))
        else:
            time.sleep(0.05)
    raise AssertionError(f"no '{needle}' within {timeout} s:\n" + "".join(stream_text))
