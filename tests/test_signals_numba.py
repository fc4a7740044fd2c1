"""A Ctrl-C that numba's dispatcher turns into a SystemError still ends a run as a Ctrl-C
(``pedvr.signals.interrupt_of``, ``signals_abort``).

Seen once in a full suite (tests/xr/monado/test_runtime.py, Ctrl-C): the interrupt landed while a
kernel's call ran numba's ``_numba_unpickle``, and came out as ``SystemError: CPUDispatcher(...)
returned a result with an exception set`` caused by the KeyboardInterrupt; the headset run ended
with a traceback instead of its outputs. The exception below has that shape."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from pedvr.headless import run_headless
from pedvr.scene.loader import load_scene
from pedvr.scenes import resolve_scene
from pedvr.signals import TerminatedBySignal, interrupt_of, signals_abort


def _dispatcher_error(cause: BaseException) -> SystemError:
    try:
        try:
            raise cause
        except BaseException as inner:
            raise SystemError("CPUDispatcher(<function pair_overlaps>) returned a result with an "
                              "exception set") from inner
    except SystemError as exc:
        return exc


def test_interrupt_of_finds_the_interrupt_behind_a_dispatcher_error() -> None:
    ki = KeyboardInterrupt()
    assert interrupt_of(_dispatcher_error(ki)) is ki
    term = TerminatedBySignal(signal.SIGTERM)
    assert interrupt_of(_dispatcher_error(term)) is term
    assert interrupt_of(_dispatcher_error(ValueError("x"))) is None
    assert interrupt_of(SystemError("plain")) is None


def test_signals_abort_lets_the_interrupt_out_as_itself() -> None:
    with pytest.raises(KeyboardInterrupt) as got:
        with signals_abort():
            raise _dispatcher_error(KeyboardInterrupt())
    assert type(got.value) is KeyboardInterrupt
    with pytest.raises(TerminatedBySignal) as term:
        with signals_abort():
            raise _dispatcher_error(TerminatedBySignal(signal.SIGTERM))
    assert term.value.name == "SIGTERM"
    with pytest.raises(SystemError):  # any other SystemError stays what it is
        with signals_abort():
            raise _dispatcher_error(ValueError("not an interrupt"))


def test_a_headless_run_cut_inside_a_kernel_call_keeps_its_outputs(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    from pedvr.sim import Simulation

    calls = {"n": 0}
    step = Simulation.step

    def cut(self: Simulation) -> None:
        calls["n"] += 1
        if calls["n"] == 20:
            raise _dispatcher_error(KeyboardInterrupt())
        step(self)

    monkeypatch.setattr(Simulation, "step", cut)
    scene = load_scene(resolve_scene("antipodal_circle"))
    summary = run_headless(scene, duration=2.0, seed=1, condition="pedvr", responsibility=None,
                           record=tmp_path / "run.npz", metrics_json=tmp_path / "metrics.json",
                           out=tmp_path, progress=False)
    assert summary["interrupted"] is True
    assert (tmp_path / "metrics.json").is_file() and (tmp_path / "run.npz").is_file()
