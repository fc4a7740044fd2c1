"""Preparing a run before its first frame: the first step and one draw, said out loud.

On a fresh install (or after an upgrade) numba compiles each kernel the first
time it runs: minutes on a small machine, with nothing on the screen; later
runs load the kernels from numba's cache (``cache=True``). An OpenGL driver
compiles its shader variants at the first draw (seconds to minutes on Mesa's
software rasteriser with an empty shader cache). Issue 25 item 13: the first
``pedvr run`` printed nothing for minutes. Issue 23 item 2: in the headset,
the compile happened after the session was already FOCUSED and the world froze
(a frame 85 s late).

Every backend therefore prepares before its frame loop:

* :func:`first_step` runs one simulation step and says what is being prepared
  while numba compiles: which phase of the step (``sense`` ... ``record``) and
  which kernel, how many compiled so far and for how long (numba's own event
  API, ``numba:compile``, fires once per kernel actually compiled; nothing
  fires when the cache answers, so a warm run prints one line).
* :func:`prepare` does that on a simulation of its own (the same scene, seed
  and condition: the run itself starts at t = 0 untouched, bit for bit as
  before), then a few more steps of it with each twin of the parallel kernels
  pinned in turn (:func:`pedvr.kernels.forcing`: which twin runs later depends
  on the machine's load, and a twin first used mid-run would compile then) and
  one with every agent's shoulders turned (:func:`twin_steps`),
  and then calls ``draw`` once (the backend draws a frame of that simulation
  offscreen with the same programs and targets it will use), so the headset's
  first ``xrWaitFrame`` comes after all of it. The first step covers what the
  scene does at its start; a kernel first needed later (an event minutes
  in) still compiles when it is first needed: :class:`CompileLog` records
  those in the run's metrics (``prepare.compiled_during_run``).

The lines go to ``say`` (stderr by default); ``say=None`` is silent (sweep
workers). The returned :class:`Prepared` goes into the run's metrics under
``prepare``.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numba.core.event as numba_event
import numpy as np

if TYPE_CHECKING:
    from pedvr.sim import Simulation

Say = Callable[[str], None]
_T = TypeVar("_T")  # what set_up builds: a simulation, or a run's simulation and presenter

PROGRESS_EVERY_S = 5.0  # at most one progress line this often while kernels compile
TWIN_STEPS = 4  # steps with each twin pinned: a decision step is among them (30 Hz decisions at 90 Hz)
PREPARE_STEPS = 4  # `pedvr prepare`'s steps: past a decision step and the 30 Hz subconscious-action tick
# after which one step with every agent's shoulders turned (twin_steps)


def stderr_say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


@dataclass
class Prepared:
    """What preparing took: wall seconds of the first step and of the first draw, kernels compiled."""

    step_s: float = 0.0
    draw_s: float | None = None
    kernels_compiled: int = 0
    compile_s: float = 0.0
    phase_s: dict[str, float] = field(default_factory=dict)
    compiled_during_run: list[str] = field(default_factory=list)  # kernels first compiled after preparing

    @property
    def total_s(self) -> float:
        return self.step_s + (self.draw_s or 0.0)

    def summary(self) -> dict[str, object]:
        return {
            "prepare_s": round(self.total_s, 3),
            "first_step_s": round(self.step_s, 4),  # with prepare(): the twin steps too
            "first_draw_s": None if self.draw_s is None else round(self.draw_s, 4),
            "kernels_compiled": self.kernels_compiled,
            "compile_s": round(self.compile_s, 3),
            "first_step_phase_s": {k: round(v, 4) for k, v in self.phase_s.items()},
            "compiled_during_run": list(self.compiled_during_run),
        }


class _CompileWatch(numba_event.Listener):  # type: ignore[misc]
    """A numba event listener: counts kernels compiled (pedvr's functions; numba's own overloads
    compiled for them are part of their compile time) and says which, at most every few seconds."""

    def __init__(self, sim: Simulation | None, say: Say | None, *, clock: Callable[[], float],
                 label: str | None = None, intro: bool = True) -> None:
        self.sim = sim
        self.label = label
        self.intro = intro  # say once what is happening (False: an earlier watch of this run said it)
        self.names: list[str] = []
        self.say = say
        self.clock = clock
        self.started = clock()
        self.compiled = 0
        self.compile_s = 0.0
        self._depth = 0
        self._outer_start = 0.0
        self._said_at = -1e9
        self._phase_said: str | None = None

    def phase(self) -> str:
        """The phase of the first step running now: the first one with no time recorded yet."""
        from pedvr.sim import PHASES

        if self.label is not None or self.sim is None:
            return self.label or "run"
        done = self.sim.metrics.phase_ms
        return next((p for p in PHASES if p not in done), "set-up")

    def on_start(self, event: Any) -> None:
        if self._depth == 0:
            self._outer_start = self.clock()
        self._depth += 1
        if self.say is None:
            return
        phase = self.phase()
        if self._phase_said is None and self.intro:
            self.say("preparing: numba is compiling pedvr's kernels (the first run after an install or "
                     "upgrade; they are cached for later runs) ...")
        if phase != self._phase_said:
            self._phase_said = phase
            self.say(f"preparing: {self._what(phase)}: compiling ...")

    def _what(self, phase: str) -> str:
        return phase if self.label is not None else f"step phase '{phase}'"

    def on_end(self, event: Any) -> None:
        self._depth -= 1
        now = self.clock()
        if self._depth == 0:
            self.compile_s += now - self._outer_start
        name = _kernel_name(event)
        if name.startswith("numba."):
            return  # numba's own overloads compiled for a kernel: part of that kernel's compile
        self.compiled += 1
        self.names.append(name)
        if self.say is not None and (now - self._said_at >= PROGRESS_EVERY_S or self.compiled == 1):
            self._said_at = now
            self.say(f"preparing: {self._what(self.phase())}: {self.compiled} kernels compiled "
                     f"({_kernel_name(event)}), {now - self.started:.0f} s so far")


def _kernel_name(event: Any) -> str:
    dispatcher = event.data.get("dispatcher") if isinstance(event.data, dict) else None
    func = getattr(dispatcher, "py_func", None)
    if func is None:
        return "a kernel"
    return f"{func.__module__}.{func.__qualname__}"


def set_up(make_sim: Callable[[], _T], *, say: Say | None = stderr_say,
           clock: Callable[[], float] = time.perf_counter) -> tuple[_T, int]:
    """``make_sim()``, saying what numba compiles while it runs (issue 27 goal 2: building the
    default scene compiles the world's kernels, the navigation mesh's and the visibility's, 22 s
    of a cold run at load 5, and said nothing). Returns the simulation and the kernels compiled;
    silent when the cache answers. Pass ``intro=not compiled`` to the :func:`first_step` after."""
    watch = _CompileWatch(None, say, clock=clock, label="scene set-up")
    with numba_event.install_listener("numba:compile", watch):
        sim = make_sim()
    if say is not None and watch.compiled:
        say(f"preparing: scene set-up: {watch.compiled} kernels compiled in {watch.compile_s:.0f} s")
    return sim, watch.compiled


class Waitable(Protocol):
    """A second process compiling the step's kernels (:class:`pedvr.warmup.Warmer`)."""

    proc: Any

    def wait(self) -> bool: ...

    def stop(self) -> None: ...


def first_step(sim: Simulation, *, say: Say | None = stderr_say,
               clock: Callable[[], float] = time.perf_counter, intro: bool = True,
               warmer: Waitable | None = None) -> Prepared:
    """Run ``sim``'s first step, saying what is compiled while it runs (module docstring).

    ``sim`` must not have stepped yet (the phase shown is read from its per-phase times).
    ``intro=False``: the run already said that numba is compiling (:func:`set_up`). ``warmer``: a
    second process compiling the step's kernels (:func:`pedvr.warmup.take`); the step waits for it,
    then loads them from numba's cache, and it is stopped after."""
    watch = _CompileWatch(sim, say, clock=clock, intro=intro)
    t0 = clock()
    if warmer is not None:
        if say is not None and warmer.proc is not None and warmer.proc.poll() is None:
            say("preparing: waiting for the step's kernels (compiling in a second process) ...")
        warmer.wait()  # then the step loads them from numba's cache, not compiling them a second time
    try:
        with numba_event.install_listener("numba:compile", watch):
            sim.step()
    finally:
        if warmer is not None:
            warmer.stop()
    out = Prepared(step_s=clock() - t0, kernels_compiled=watch.compiled, compile_s=watch.compile_s,
                   phase_s={k: v / 1e3 for k, v in sim.metrics.phase_ms.items()})
    if say is not None and watch.compiled:
        say(f"preparing: {watch.compiled} kernels compiled in {watch.compile_s:.0f} s; "
            "the next run loads them from numba's cache")
    return out


def twin_steps(sim: Simulation, *, say: Say | None = stderr_say,
               clock: Callable[[], float] = time.perf_counter, twins: bool = True) -> tuple[int, float]:
    """:data:`TWIN_STEPS` steps with every parallel kernel's parallel twin, then as many with its
    serial twin (:func:`pedvr.kernels.forcing`; not with ``twins=False``, as ``pedvr prepare``
    without ``--view`` for a headless run), then one step with every agent's shoulders
    turned; return the kernels compiled and the seconds. ``sim`` is preparing's own and is
    thrown away after.

    The last step is there because a scene's first steps rarely have anyone squeezing past
    someone: the kernels of turned footprints (the distance to walls of a turned body,
    :mod:`pedvr.crowd.footprint`) then compiled mid-run, seconds into the headset session
    (a 4 s frame against Monado on a loaded machine). Turning every shoulder in a simulation
    nobody sees makes them compile now."""
    from pedvr.kernels import forcing

    label = "both twins of the parallel kernels" if twins else "turned shoulders"
    watch = _CompileWatch(None, say, clock=clock, label=label)
    with numba_event.install_listener("numba:compile", watch):
        for parallel in (True, False) if twins else ():
            with forcing(parallel):
                for _ in range(TWIN_STEPS):
                    sim.step()
                _line_of_sight(sim)
        if not twins:
            _line_of_sight(sim)
        crowd = sim.crowd
        if len(crowd):
            # Fully turned: above any walking body's turn (coupled walkers are ellipses already,
            # turn_for(depth_ratio), and only bodies turned beyond it meet the wall kernels).
            crowd.turn[:] = np.where(crowd.is_user, 0.0, 1.0)
            crowd.torso[:] = crowd.heading + 0.5 * np.pi
            sim.step()
    return watch.compiled, watch.compile_s


def _line_of_sight(sim: Simulation) -> None:
    """One line-of-sight query of the scene's walls (:meth:`pedvr.world.visibility.Visibility.visible`),
    as the gaze rule, path following and behaviour trees ask it. A scene's first steps often ask
    none (nobody near the user yet, no waypoint due), so its kernel compiled mid-run: on a cold
    cache the first ``pedvr run`` after ``pedvr prepare`` compiled ``visible_batch_grid``'s serial
    twin seconds into the run. The query reads the world and changes nothing."""
    pos = sim.crowd.pos[:1] if len(sim.crowd) else np.zeros((1, 2))
    sim.visibility.visible(pos, pos + 0.5)


class CompileLog:
    """Kernels compiled inside the block (``with CompileLog() as log: ...``; :attr:`names`): what
    preparing did not reach, for the run's metrics."""

    def __init__(self) -> None:
        self._watch = _CompileWatch(None, None, clock=time.perf_counter, label="run")

    @property
    def names(self) -> list[str]:
        return self._watch.names

    def __enter__(self) -> CompileLog:
        numba_event.register("numba:compile", self._watch)
        return self

    def __exit__(self, *exc: object) -> None:
        numba_event.unregister("numba:compile", self._watch)


def prepare(
    make_sim: Callable[[], Simulation],
    *,
    what: str,
    draw: Callable[[Simulation], object] | None = None,
    say: Say | None = stderr_say,
    clock: Callable[[], float] = time.perf_counter,
    warmer: Waitable | None = None,
) -> Prepared:
    """Prepare a frame loop: the first step of a simulation of its own (``make_sim()``: the same
    scene as the run) and one ``draw`` of it; one line when done (more while compiling)."""
    if say is not None:
        say(f"preparing {what}: the first step{' and the first frame' if draw else ''} ...")
    sim, compiled = set_up(make_sim, say=say, clock=clock)  # says what building the scene compiles
    out = first_step(sim, say=say, clock=clock, intro=not compiled, warmer=warmer)
    out.kernels_compiled += compiled
    t0 = clock()
    n, seconds = twin_steps(sim, say=say, clock=clock)
    out.step_s += clock() - t0
    out.kernels_compiled += n
    out.compile_s += seconds
    if draw is not None:
        if say is not None and out.step_s > 1.0:
            say("preparing: drawing the first frame (the OpenGL driver compiles its shaders) ...")
        t0 = clock()
        draw(sim)
        out.draw_s = clock() - t0
    if say is not None:
        frame = "" if out.draw_s is None else f", first frame {out.draw_s:.1f} s"
        say(f"prepared in {out.total_s:.1f} s (first steps {out.step_s:.1f} s, "
            f"{out.kernels_compiled} kernels compiled{frame})")
    return out
