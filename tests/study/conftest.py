"""Shared fixtures: a shortened copy of the shipped protocol, and a small one."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest
import tomli_w

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "user_study" / "pedvr_replication.toml"
STANDARD = ROOT / "user_study" / "standard_measures.toml"
QDIR_SHIPPED = ROOT / "user_study" / "questionnaires"
DATA = Path(__file__).resolve().parent / "data"


def shortened_protocol(folder: Path, *, block_s: float = 0.4, corridor_s: float = 0.5, training_s: float = 0.3,
                       source: Path = SHIPPED) -> Path:
    """A shipped protocol (default: the replication) with short trials (the tests' headless dry run);
    otherwise unchanged."""
    data = tomllib.loads(source.read_text())
    data["study"]["questionnaire_dir"] = str(ROOT / "user_study" / "questionnaires")
    for step in data["steps"]:
        if step["kind"] == "trial":
            step["time_limit_s"] = training_s
            step["scene"] = str(ROOT / "user_study" / step["scene"])
        elif step["kind"] == "sweep":
            step["time_limit_s"] = corridor_s
        elif step["kind"] == "blocks":
            for b in step["blocks"]:
                b["time_limit_s"] = block_s
    out = folder / f"{source.stem}_short.toml"
    out.write_bytes(tomli_w.dumps(data).encode())
    return out


@pytest.fixture
def mini_protocol() -> Path:
    return DATA / "mini.toml"


def run_session(protocol: Path, store: object, pid: str, *, participant: object = None, keys: object = None,
                resume: bool = False, clock: object = None) -> tuple[object, str]:
    """Run (or resume) ``pid`` headless through ``protocol``; return the result and the console text."""
    import io

    from pedvr.study.console import ExperimenterConsole, NoKeys
    from pedvr.study.presenter import SimulatedParticipant
    from pedvr.study.protocol import load_protocol, participant_number
    from pedvr.study.session import Session

    p = load_protocol(protocol)
    out = io.StringIO()
    kw = {} if clock is None else {"clock": clock}
    console = ExperimenterConsole(out=out, keys=keys or NoKeys(), live=False, **kw)
    who = participant or SimulatedParticipant(seed=p.seed, number=participant_number(pid))
    result = Session(protocol=p, store=store, participant_id=pid, participant=who, console=console,
                     backend="headless", resume=resume, simulated=True).run()
    return result, out.getvalue()


class InterruptingParticipant:
    """A simulated participant whose ``present`` raises ``exc`` at the ``at``-th trial frame (once)."""

    def __init__(self, inner: object, *, at: int, exc: BaseException) -> None:
        self.inner, self.at, self.exc, self.frames, self.fired = inner, at, exc, 0, False
        self.kind = "simulated"

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)

    def present(self, sim: object) -> float:
        self.frames += 1
        if self.frames == self.at and not self.fired:
            self.fired = True
            raise self.exc
        return self.inner.present(sim)  # type: ignore[attr-defined]


@pytest.fixture
def read_only():
    """``read_only(path, ...)``: make files and folders unwritable for this test, even for root.

    Not root: chmod (files 0444, folders 0555). Root ignores modes, so there the
    files and folders get the immutable attribute (``chattr +i``); where that is
    not possible the test is skipped with the reason. Everything is made
    writable again afterwards.
    """
    import os
    import shutil
    import stat
    import subprocess

    done: list[tuple[Path, int | None]] = []

    def make(*paths: Path) -> None:
        for p in paths:
            if os.geteuid() == 0:
                if shutil.which("chattr") is None:
                    pytest.skip("running as root and chattr is missing: cannot make a file read-only")
                r = subprocess.run(["chattr", "+i", str(p)], capture_output=True, text=True)
                if r.returncode != 0:
                    pytest.skip(f"running as root and chattr +i failed here ({r.stderr.strip()}): "
                                "cannot make a file read-only")
                done.append((p, None))
            else:
                mode = p.stat().st_mode
                p.chmod(0o555 if p.is_dir() else 0o444)
                done.append((p, stat.S_IMODE(mode)))

    yield make
    for p, mode in reversed(done):
        if mode is None:
            subprocess.run(["chattr", "-i", str(p)], check=False)
        else:
            p.chmod(mode)
