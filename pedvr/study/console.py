"""The experimenter console: progress in the terminal, and keys to pause, skip and abort.

It shows where the session is in the protocol (step k of n), the current
trial and its simulated time, the elapsed session time and what comes next.
Keys, read without Enter while a trial runs and between steps:

``p``  pause (the simulation stops; ``p`` again resumes)
``s``  skip the current step; asks for a reason, which is recorded
``a``  abort the session; asks for confirmation (``yes``); ``--resume`` continues later
``h``  help

Keys come from a :class:`KeySource`: :class:`TerminalKeys` for a real
terminal, :class:`ScriptedKeys` to inject a key stream in tests. Time comes
from an injected clock.
"""

from __future__ import annotations

import os
import select
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Protocol, TextIO

from pedvr.study.errors import StudyStoreError

HELP = "keys: p pause/resume, s skip (with a reason), a abort, h help"


class KeySource(Protocol):
    def poll(self) -> str | None:
        """The next key if one is waiting, else ``None``; never blocks."""
        ...

    def wait(self) -> str:
        """Block until a key arrives."""
        ...

    def read_line(self, prompt: str) -> str:
        """Read a line (a skip reason, an abort confirmation)."""
        ...

    @contextmanager
    def live(self) -> Iterator[None]:
        """Keys are read one by one inside this block (a trial running)."""
        ...


class ScriptedKeys:
    """Keys from a list, for tests: each :meth:`poll` takes the next entry.

    ``None`` entries mean "no key at this poll"; strings are keys, or the
    answer to a :meth:`read_line` prompt. Past the end, polls return ``None``;
    waiting or reading past the end is an error (a test that would hang).
    """

    def __init__(self, keys: Iterable[str | None]) -> None:
        self._keys = list(keys)
        self._at = 0
        self.prompts: list[str] = []

    def _next(self) -> str | None:
        if self._at >= len(self._keys):
            raise StudyStoreError("scripted experimenter keys ran out while the console waited for input")
        k = self._keys[self._at]
        self._at += 1
        return k

    def poll(self) -> str | None:
        if self._at >= len(self._keys):
            return None
        return self._next()

    def wait(self) -> str:
        while True:
            k = self._next()
            if k is not None:
                return k

    def read_line(self, prompt: str) -> str:
        self.prompts.append(prompt)
        return self.wait()

    @contextmanager
    def live(self) -> Iterator[None]:
        yield


class NoKeys:
    """No experimenter at the keyboard (non-interactive runs): nothing ever arrives."""

    def poll(self) -> str | None:
        return None

    def wait(self) -> str:
        raise StudyStoreError("the console needs a key but has no keyboard (stdin is not a terminal)")

    def read_line(self, prompt: str) -> str:
        return self.wait()

    @contextmanager
    def live(self) -> Iterator[None]:
        yield


class TerminalKeys:
    """Keys from a terminal's stdin; single keys without Enter inside :meth:`live`."""

    def __init__(self, stdin: TextIO = sys.stdin, stdout: TextIO = sys.stdout) -> None:
        self.stdin = stdin
        self.stdout = stdout
        self.fd = stdin.fileno()

    def poll(self) -> str | None:
        ready, _, _ = select.select([self.fd], [], [], 0)
        if not ready:
            return None
        data = os.read(self.fd, 1)
        return data.decode("utf-8", "replace") if data else None

    def wait(self) -> str:
        while True:
            select.select([self.fd], [], [])
            k = self.poll()
            if k is not None and k.strip():
                return k

    def read_line(self, prompt: str) -> str:
        self.stdout.write(prompt)
        self.stdout.flush()
        return self.stdin.readline().rstrip("\n")

    @contextmanager
    def live(self) -> Iterator[None]:
        if not os.isatty(self.fd):
            yield
            return
        import termios
        import tty

        saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)
        try:
            yield
        finally:
            termios.tcsetattr(self.fd, termios.TCSADRAIN, saved)


@dataclass(frozen=True)
class Command:
    """What the experimenter asked for: ``skip`` (with ``reason``) or ``abort``."""

    kind: str
    reason: str = ""


def clock_text(seconds: float) -> str:
    s = int(max(seconds, 0.0))
    return f"{s // 3600:02d}:{s % 3600 // 60:02d}:{s % 60:02d}"


class ExperimenterConsole:
    """Progress lines and key handling for one session.

    ``on_event(kind, detail)`` is called for pause, resume, skip and abort,
    so the session can record them. In ``live`` mode (a terminal) the trial
    status line is redrawn in place at most ``refresh_s`` apart.
    """

    def __init__(
        self,
        *,
        out: TextIO,
        keys: KeySource,
        clock: Callable[[], float] = time.monotonic,
        live: bool | None = None,
        refresh_s: float = 0.25,
    ) -> None:
        self.out = out
        self.keys = keys
        self.clock = clock
        self.live = out.isatty() if live is None else live
        self.refresh_s = refresh_s
        self.started = clock()
        self.on_event: Callable[[str, str | None], None] = lambda kind, detail: None
        self._last_draw = -1e9
        self.paused_s = 0.0

    def elapsed(self) -> float:
        return self.clock() - self.started

    def say(self, line: str) -> None:
        if self.live:
            self.out.write("\r\x1b[K")
        self.out.write(line + "\n")
        self.out.flush()

    def session_started(self, *, participant: str, protocol: str, resumed_at: int | None, total: int) -> None:
        how = "new session" if resumed_at is None else f"resuming at step {resumed_at + 1}/{total}"
        self.say(f"participant {participant}: {protocol}: {how}. {HELP}")

    def step_started(self, *, index: int, total: int, title: str, next_title: str | None) -> None:
        nxt = next_title if next_title is not None else "end of protocol"
        self.say(f"[{index + 1:>2}/{total}] {title} | elapsed {clock_text(self.elapsed())} | next: {nxt}")

    def step_finished(self, *, index: int, total: int, title: str, status: str, detail: str = "") -> None:
        self.say(f"[{index + 1:>2}/{total}] {status}: {title}{' (' + detail + ')' if detail else ''}")

    def trial_status(self, *, sim_t: float, limit_s: float, spheres: int, spheres_total: int) -> None:
        if not self.live:
            return
        now = self.clock()
        if now - self._last_draw < self.refresh_s:
            return
        self._last_draw = now
        self.out.write(
            f"\r\x1b[K    trial t = {sim_t:6.1f} / {limit_s:.0f} s, spheres {spheres}/{spheres_total}, "
            f"elapsed {clock_text(self.elapsed())}  [{HELP}]"
        )
        self.out.flush()

    def check(self) -> Command | None:
        """Handle any waiting key. Pausing blocks here until resumed."""
        k = self.keys.poll()
        while k is not None:
            k = k.lower()
            if k == "p":
                self._pause()
            elif k == "s":
                reason = self.keys.read_line("skip this step: reason (empty cancels)? ").strip()
                if reason:
                    self.say(f"skipping: {reason}")
                    return Command("skip", reason)
                self.say("skip cancelled")
            elif k == "a":
                if self.keys.read_line("abort the session? type yes to abort: ").strip().lower() == "yes":
                    self.say("aborting; continue later with --resume")
                    return Command("abort")
                self.say("abort cancelled")
            elif k in ("h", "?"):
                self.say(HELP)
            k = self.keys.poll()
        return None

    def _pause(self) -> None:
        start = self.clock()
        self.on_event("pause", None)
        self.say(f"paused at {clock_text(self.elapsed())}; press p to resume")
        while self.keys.wait().lower() != "p":
            self.say("paused; press p to resume")
        self.paused_s += self.clock() - start
        self.on_event("resume", f"paused {self.clock() - start:.1f} s")
        self.say("resumed")
