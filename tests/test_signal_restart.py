"""A signal never fails a runtime call in progress inside :func:`pedvr.signals.calls_restart`.

Monado's client library waits for the compositor in ``recvmsg``; a Ctrl-C or SIGTERM landing
there made the call fail with EINTR, the run reported the runtime lost and could not end its
session politely (``tests/xr/monado/test_runtime.py``'s signal test saw the last state FOCUSED
now and then). The same happens to any C call blocked in the kernel, so the test blocks one
itself: libc ``read`` on a pipe (through ctypes, as pyopenxr calls the loader), in a child
process's main thread, while another thread sends the signal to that thread and then writes.
With the block the read goes on, takes the byte and the handler's exception comes after it;
without it the read fails at once (EINTR) and the byte stays in the pipe.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

CHILD = r"""
import ctypes, json, os, signal, sys, threading, time
from contextlib import nullcontext
from pedvr.signals import calls_restart, signals_abort

libc = ctypes.CDLL(None, use_errno=True)
sig = getattr(signal, sys.argv[1])
restart = calls_restart() if sys.argv[2] == "restart" else nullcontext()
r, w = os.pipe()
main = threading.main_thread().ident
t0 = time.monotonic()

def poke():
    time.sleep(0.3)
    signal.pthread_kill(main, sig)  # to the thread blocked in read, as it lands in recvmsg
    time.sleep(0.5)
    os.write(w, b"x")

buf = ctypes.create_string_buffer(1)
out = {}
try:
    with signals_abort(), restart:
        threading.Thread(target=poke, daemon=True).start()
        libc.read(r, buf, 1)  # the handler's exception comes when the call returns
        out["finished"] = True
except KeyboardInterrupt as exc:  # Ctrl-C's, or TerminatedBySignal
    out["raised"] = type(exc).__name__
    out["after_s"] = round(time.monotonic() - t0, 1)
time.sleep(0.8)  # past the write
os.set_blocking(r, False)
try:
    out["left_in_pipe"] = len(os.read(r, 1))  # 0 if the blocked read took the byte
except BlockingIOError:
    out["left_in_pipe"] = 0
print(json.dumps(out))
"""


def _child(sig: str, mode: str) -> dict[str, object]:
    proc = subprocess.run([sys.executable, "-c", CHILD, sig, mode], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("sig, raised", [("SIGTERM", "TerminatedBySignal"), ("SIGINT", "KeyboardInterrupt"),
                                         ("SIGHUP", "TerminatedBySignal")])
def test_a_signal_inside_the_block_lets_the_call_finish_then_ends_the_run(sig: str, raised: str) -> None:
    """The read went on until the byte came (0.8 s), took it, and then the signal ended the block."""
    out = _child(sig, "restart")
    assert out["raised"] == raised and out["left_in_pipe"] == 0 and out["after_s"] >= 0.7, out


def test_outside_the_block_the_same_signal_fails_the_call() -> None:
    """What the block is for: without it the blocked call fails when the signal lands (0.3 s; the
    runtime call that failed and made the session look lost), and the byte is never read."""
    out = _child("SIGTERM", "plain")
    assert out["raised"] == "TerminatedBySignal" and out["left_in_pipe"] == 1 and out["after_s"] < 0.7, out
