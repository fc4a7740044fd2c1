"""SIGTERM and SIGHUP end a run or a study session like Ctrl-C: ``aborted``, with a logged event.

A session killed politely (``kill PID``, a closed terminal, a desktop logging
out) should leave the database as an abort by the experimenter would: the
session ``aborted``, an ``abort`` event naming the signal, a running trial
marked ``interrupted`` with its samples kept, and ``--resume`` continuing at
the first unfinished step. Inside :func:`signals_abort` the two signals raise
:class:`TerminatedBySignal` (a :class:`KeyboardInterrupt`, so every place that
already winds down on Ctrl-C does the same for them); later signals are
ignored while the session winds down, so the clean-up itself is not cut short.
An interrupt that numba's dispatcher turned into a ``SystemError`` leaves the
block as the interrupt it was (:func:`interrupt_of`).
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

SIGNALS = ("SIGTERM", "SIGHUP")


class TerminatedBySignal(KeyboardInterrupt):
    """The process received ``signum`` (SIGTERM or SIGHUP) while a session ran."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        self.name = signal.Signals(signum).name
        super().__init__(f"{self.name} received")

    @property
    def exit_code(self) -> int:
        """The shell's convention for a process ended by a signal: 128 + its number."""
        return 128 + self.signum


@contextmanager
def signals_abort() -> Iterator[None]:
    """Turn SIGTERM and SIGHUP into :class:`TerminatedBySignal` inside the block (main thread only).

    Outside the main thread Python cannot install handlers; the block then
    runs with the handlers it had. The previous handlers are restored on exit. A Ctrl-C or signal
    that numba's dispatcher turned into a ``SystemError`` leaves the block as itself
    (:func:`interrupt_of`).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    fired = False

    def handler(signum: int, frame: FrameType | None) -> None:
        nonlocal fired
        if fired:  # already winding down: let the clean-up finish
            return
        fired = True
        raise TerminatedBySignal(signum)

    numbers = [getattr(signal, n) for n in SIGNALS if hasattr(signal, n)]
    previous = {s: signal.signal(s, handler) for s in numbers}
    try:
        yield
    except SystemError as exc:
        ki = interrupt_of(exc)
        if ki is None:
            raise
        raise ki from None  # (ki caused exc: chaining exc again would make a loop of causes)
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def interrupt_of(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C (or :class:`TerminatedBySignal`) behind ``exc``, if its causes hold one.

    A signal's handler runs between Python bytecodes, and numba's dispatcher runs some Python while
    a kernel is called (``_numba_unpickle``, for an object the kernel refers to). A Ctrl-C landing
    there comes out of the kernel call as ``SystemError: CPUDispatcher(...) returned a result with
    an exception set``, caused by the KeyboardInterrupt, and got past every ``except
    KeyboardInterrupt`` that winds a run down: a headset run ended with a traceback instead of its
    outputs (tests/xr/monado/test_runtime.py, Ctrl-C, once in a full suite).
    :func:`signals_abort` re-raises the interrupt itself."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


@contextmanager
def calls_restart() -> Iterator[None]:
    """Inside the block, Ctrl-C, SIGTERM and SIGHUP no longer interrupt a system call in progress:
    the kernel restarts it (``SA_RESTART``) and Python's handler runs once it returns (main thread
    only; each signal's handler is kept).

    For the OpenXR frame loop: a signal landing while Monado's client library waited in ``recvmsg``
    made that call fail, and the run reported the runtime lost and could no longer end its session
    politely (the session's last state FOCUSED, not EXITING). Which call a signal lands in is
    chance, so without this a polite ``kill`` ended the session politely only most of the time.
    The price: a runtime call that never returns (a runtime hung while alive) cannot be broken by a
    signal either; a runtime that dies closes its socket, and the call returns.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    numbers = [getattr(signal, n) for n in ("SIGINT", *SIGNALS) if hasattr(signal, n)]
    for s in numbers:
        signal.siginterrupt(s, False)
    try:
        yield
    finally:
        for s in numbers:
            signal.siginterrupt(s, True)
