"""The experimenter's key reader on a real terminal (a pseudo-terminal): single keys arrive
without Enter inside ``live()``, a reason is read as a line, and the terminal's modes are
restored afterwards, also when the session inside ends with an error."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time

import pytest

pty = pytest.importorskip("pty")

CHILD = r"""
import sys, termios
from pedvr.study.console import TerminalKeys

keys = TerminalKeys()
before = termios.tcgetattr(keys.fd)
try:
    with keys.live():
        inside = termios.tcgetattr(keys.fd)
        print("ready", flush=True)
        print("got", keys.wait(), flush=True)
        print("polled", repr(keys.poll()), flush=True)
        print("reason", repr(keys.read_line("reason? ")), flush=True)
        raise RuntimeError("the session failed")
except RuntimeError:
    pass
after = termios.tcgetattr(keys.fd)
print("canonical inside", bool(inside[3] & termios.ICANON), flush=True)
print("restored", after == before, flush=True)
"""


def _read_until(fd: int, text: str, timeout: float = 20.0) -> str:
    buf = ""
    end = time.monotonic() + timeout
    while text not in buf:
        left = end - time.monotonic()
        if left <= 0:
            raise AssertionError(f"waited for {text!r}; the terminal showed {buf!r}")
        ready, _, _ = select.select([fd], [], [], left)
        if ready:
            try:
                chunk = os.read(fd, 1024)
            except OSError:  # the child closed the terminal
                break
            buf += chunk.decode("utf-8", "replace")
    return buf


def test_keys_without_enter_a_line_for_the_reason_and_modes_restored() -> None:
    parent, child = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-c", CHILD], stdin=child, stdout=child, stderr=child,
                            close_fds=True)
    os.close(child)
    try:
        _read_until(parent, "ready")
        os.write(parent, b"p")  # no Enter: cbreak mode delivers it at once
        shown = _read_until(parent, "reason? ")
        assert "got p" in shown and "polled None" in shown
        os.write(parent, b"too loud\n")
        shown = _read_until(parent, "restored")
        shown += _read_until(parent, "\n", timeout=5)
        assert "reason 'too loud'" in shown
        assert "canonical inside False" in shown
        assert "restored True" in shown
        assert proc.wait(timeout=20) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(parent)
