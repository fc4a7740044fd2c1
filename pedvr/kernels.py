"""numba kernels that run in parallel only where one thread would not do, measured as they run.

A ``prange`` loop is a fork–join: every launch waits for every worker
thread. For the tens of agents of a VR scene that wait costs more than the
work, and on a busy machine — a renderer thread, a compositor, an OpenXR
runtime on the same cores — a worker that is descheduled stalls the whole
join for a scheduler quantum, milliseconds, while a single thread merely runs
a little slower. So each parallel kernel gets a serial twin compiled from the
same source, and a :class:`Chooser` picks one per call:

* fewer than ``SERIAL_ROWS`` rows, or one numba thread: always serial;
* serial while the serial twin's call fits in ``SERIAL_BUDGET_S`` (its measured
  cost per row, an exponential average of wall time per row, times the rows): a
  kernel that one thread runs in under 0.5 ms takes no other core, which keeps a
  headset scene's tens of people on one thread. Issue 12 set the budget at 2 ms, so
  that a step that never waits on another thread takes as long on a loaded machine
  as on a quiet one, as single-threaded RVO2 does (``pedvr bench steering --vs rvo2
  --load 0 --load 1``). But the whole step with bodies (issue 27) is several kernels
  of 0.3-1 ms each at 1000 agents, and at 2 ms all of them ran on one thread while a
  core stood free: ``pedvr bench sim --agents 1000 --load 0 --load 1 --vs rvo2``,
  2-core VM, one session, gave p50 3.85 ms quiet and 3.83 ms beside a busy process
  at 2 ms, 2.93 and 3.58 ms at 0.5 ms (0.3 and 0.15 ms gave the same as 0.5; 100 and
  4000 agents were unchanged). Loaded, the chooser finds the serial twins cheaper
  and keeps them, so the loaded step is no slower than before; only the quiet one
  gained. The first call of a kernel runs serial, to measure it;
* over the budget, the twin whose measured cost per row is lower; parallel is
  tried first, and the other twin is re-tried now and then to notice a change in
  the machine's load: after ``EXPLORE_FIRST`` calls, then with the gap doubling
  each time it loses, up to ``EXPLORE_MAX`` calls (about 20 s at 90 Hz for a
  once-per-step kernel), so a loaded machine pays a slow parallel call rarely. A
  try's time replaces the twin's old cost; if it was a lucky one, the next calls
  average it back up and the chooser switches back. A serial try that fits the
  budget again returns the kernel to one thread;
* when the twin in use turns dearer than the other (one slow call, a worker
  descheduled, is enough to tip the average), the other is re-tried after
  ``EXPLORE_FIRST`` calls, not after the backed-off gap: a hiccup costs a few
  calls on the slower twin, not a backed-off gap of up to ``EXPLORE_MAX``.

Results do not depend on the choice: the kernels' outputs are written per row,
with no reductions across threads, so the bytes are the same whatever twin ran
and however many threads there are (tests/test_kernels.py). Only the timing
depends on the machine.
"""

from __future__ import annotations

import math
import time
import types
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numba
from numba import njit

SERIAL_ROWS = 64  # below this, never parallel
SERIAL_BUDGET_S = 0.0005  # a call one thread runs in this long, or less, stays on one thread
EXPLORE_FIRST = 8
EXPLORE_MAX = 2048
ALPHA = 0.25  # weight of the newest measurement in the running cost


def row_njit(*, fastmath: Any = None, inline: str = "never") -> Any:
    """``njit`` for what kernels call once per row or per neighbour: functions that
    allocate nothing and return no array (issue 12).

    numba counts references to every array a compiled function receives or slices, an
    atomic increment and decrement per array per call. ORCA passes some thirty arrays
    down five calls deep, per agent and per neighbour, and counting them cost more than
    the geometry: the steering core took 1.19 ms a step on one thread at 1000 agents
    with the counting and 0.65 ms without (``NUMBA_NUM_THREADS=1 pedvr bench steering
    --agents 1000 --vs rvo2``, before and after; the bytes are the same). These
    functions are compiled without numba's runtime (``_nrt=False``): one that allocates
    fails to compile, loudly, and one may not return an array (nothing would own it).
    ``fastmath`` unset means the caller's flags, as for ``njit``. (numpy's error model,
    which drops the zero test before each division, saved a little more but changed
    ORCA's rounding enough to make a coupled agent's own motion limits infeasible in
    tests/crowd/test_steering.py: not used.)
    """
    options: dict[str, Any] = {"cache": True, "_nrt": False, "inline": inline}
    if fastmath is not None:  # unset, numba compiles it with its caller's fastmath flags
        options["fastmath"] = fastmath
    return njit(**options)


CHOOSERS: list[Chooser] = []  # every chooser made, for benchmarks that warm both twins up


@contextmanager
def forcing(parallel: bool) -> Iterator[None]:
    """Pin every chooser to one twin inside the block (benchmarks warm both twins up
    before timing, so loading a twin's compiled code is not timed)."""
    saved = [c.forced for c in CHOOSERS]
    for c in CHOOSERS:
        c.forced = parallel
    try:
        yield
    finally:
        for c, f in zip(CHOOSERS, saved, strict=True):
            c.forced = f


class Chooser:
    """Serial or parallel for the next call, from measured cost (see the module docstring)."""

    __slots__ = ("serial_rows", "cost", "gap", "count", "exploring", "calls", "forced")

    def __init__(self, serial_rows: int = SERIAL_ROWS) -> None:
        self.serial_rows = serial_rows  # below this many rows, never parallel
        self.forced: bool | None = None  # pin a twin (tests, experiments); None: measure
        CHOOSERS.append(self)
        self.cost = [math.nan, math.nan]  # seconds per row: [serial, parallel]
        self.gap = EXPLORE_FIRST
        self.count = 0
        self.exploring = False
        self.calls = [0, 0]

    def choose(self, n: int) -> bool:
        """True for the parallel twin. Call :meth:`record` with the time the call took."""
        if self.forced is not None:
            self.exploring = False
            return self.forced
        serial, par = self.cost
        if n < self.serial_rows or numba.get_num_threads() < 2 or not serial * n > SERIAL_BUDGET_S:
            self.exploring = False  # tiny, one thread, not measured yet (NaN), or fits the budget
            return False
        best = math.isnan(par) or par < serial
        self.count += 1
        self.exploring = self.count >= self.gap
        if self.exploring:
            self.count = 0
            return not best
        return best

    def record(self, parallel: bool, n: int, seconds: float) -> None:
        if n < self.serial_rows or n == 0:
            return
        k = int(parallel)
        self.calls[k] += 1
        c = seconds / n
        old = self.cost[k]
        # A rare try replaces what was known (it may be minutes old); calls in a row average.
        self.cost[k] = c if math.isnan(old) or self.exploring else old + ALPHA * (c - old)
        other = self.cost[1 - k]
        if self.exploring:
            won = not math.isnan(other) and self.cost[k] < other
            self.gap = EXPLORE_FIRST if won else min(2 * self.gap, EXPLORE_MAX)
            self.exploring = False
        elif not math.isnan(old) and old <= other < self.cost[k]:
            # The twin in use just became the dearer one: one slow call (a worker descheduled)
            # can do that. Re-try the other soon rather than after a long backed-off gap, so a
            # hiccup costs a few calls on the slower twin, not thousands.
            self.gap = EXPLORE_FIRST
            self.count = 0


class SizeDispatch:
    """Call the serial or the parallel twin, as its :class:`Chooser` decides, and time it."""

    def __init__(self, parallel: Any, serial: Any) -> None:
        self.parallel = parallel
        self.serial = serial
        self.chooser = Chooser()
        self.__doc__ = parallel.py_func.__doc__
        self.__wrapped__ = parallel.py_func

    def __call__(self, *args: Any) -> Any:
        n = args[0].shape[0]
        par = self.chooser.choose(n)
        t0 = time.perf_counter()
        out = (self.parallel if par else self.serial)(*args)
        self.chooser.record(par, n, time.perf_counter() - t0)
        return out


def parallel_kernel(*, fastmath: Any = False, allocates: bool = True) -> Callable[[Any], SizeDispatch]:
    """Decorator: ``njit(cache=True, parallel=True)`` plus a serial twin.

    The twin gets its own qualified name so numba's on-disk cache keeps the
    two compilations apart. ``allocates=False``: a kernel that allocates nothing
    and returns nothing but scalars; both twins are compiled as :func:`row_njit`
    compiles (no reference counting).
    """
    options: dict[str, Any] = {"cache": True, "fastmath": fastmath}
    if not allocates:
        options.update(_nrt=False)

    def wrap(f: Callable[..., Any]) -> SizeDispatch:
        par = njit(parallel=True, **options)(f)
        twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "_serial", f.__defaults__,
                                  f.__closure__)
        twin.__qualname__ = f.__qualname__ + "_serial"
        twin.__module__ = f.__module__
        ser = njit(**options)(twin)
        return SizeDispatch(par, ser)

    return wrap


@njit(cache=True, inline="always")
def wrap_pi(a):  # type: ignore[no-untyped-def]
    """``(a + π) % (2π) − π`` (an angle wrapped to ``[-π, π)``), bit for bit as numba computes it,
    mostly without its fmod. numba compiles Python's float modulo as ``fmod`` plus a sign fix
    (CPython's ``float_divmod``), the fmod a call into numba's helper library. Where ``a + π``
    lies within one turn of 0, as the wrap of a heading difference nearly always does, fmod
    returns ``a + π`` itself, exactly, and the modulo is that, or that plus 2π: the same
    operations, without the call (issue 27: the call was about 1 % of a 1000-agent step's CPU
    time). Inlined where it is called, so it runs under the caller's fastmath flags, as the
    expression it stands for did (tests/test_kernels.py)."""
    x = a + math.pi
    y = 2.0 * math.pi
    if 0.0 < x < y:  # fmod(x, y) is x: the sign of y already
        return x - math.pi
    if -y < x < 0.0:  # fmod(x, y) is x: the sign fix adds y
        return (x + y) - math.pi
    return x % y - math.pi  # zero (the modulo's signed zero), NaN, more than a turn away


# -- sine and cosine for the pose kernels (issue 27) ------------------------------------------------
# glibc's sin, cos and sincos were a quarter of the pose graph kernel's time (perf, 1000-agent plaza,
# one thread): a body's pose takes some thirty half-angle sine-cosine pairs (Euler angles to
# quaternions, the legs' and feet's rotations) and a dozen phase sines. These are fdlibm's
# (Sun Microsystems 1993; the k_sin.c, k_cos.c and e_rem_pio2.c that FreeBSD's libm and musl still
# use): the argument reduced by π/2 in three pieces of 33 bits (more of them only where the first
# cancels, as fdlibm does; exact for |x| < 2**20 π/2), then the kernels' polynomials on
# |r| ≤ π/4 with the reduction's tail. Against glibc's: never more than 1 ulp apart
# (tests/test_kernels.py), at about a third of the time for the pose's small angles. Arguments
# beyond _TRIG_FAST, NaN and ±inf go to glibc.
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
_PIO4 = 7.85398163397448278999e-01
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1, _PIO2_1T = 1.57079632673412561417e+00, 6.07710050650619224932e-11  # 33 bits of π/2, the rest
_PIO2_2, _PIO2_2T = 6.07710050630396597660e-11, 2.02226624879595063154e-21  # the next 33, the rest
_PIO2_3, _PIO2_3T = 2.02226624871116645580e-21, 8.47842766036889956997e-32  # the next 33, the rest
_TRIG_FAST = 1.0e5  # |x| up to this is reduced here (|n| < 2**17, so n × a 33-bit piece is exact)


@njit(cache=True, inline="always")
def _ksin(x, y):  # type: ignore[no-untyped-def]
    """sin(x + y) for |x| ≤ π/4, |y| a tail below half an ulp of x (fdlibm's __kernel_sin)."""
    z = x * x
    v = z * x
    r = _S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))
    return x - ((z * (0.5 * y - v * r) - y) - v * _S1)


@njit(cache=True, inline="always")
def _kcos(x, y):  # type: ignore[no-untyped-def]
    """cos(x + y) for |x| ≤ π/4 (fdlibm's __kernel_cos)."""
    z = x * x
    r = z * (_C1 + z * (_C2 + z * (_C3 + z * (_C4 + z * (_C5 + z * _C6)))))
    hz = 0.5 * z
    w = 1.0 - hz
    return w + (((1.0 - w) - hz) + (z * r - x * y))


@njit(cache=True, inline="always")
def _reduce(x):  # type: ignore[no-untyped-def]
    """``x = r + t + n π/2`` with ``|r| ≲ π/4`` and ``t`` its tail: ``(r, t, n mod 4)`` (fdlibm's
    __ieee754_rem_pio2 for medium arguments)."""
    fn = math.floor(x * _INVPIO2 + 0.5)
    r = x - fn * _PIO2_1
    w = fn * _PIO2_1T
    y0 = r - w
    if abs(y0) < abs(x) * 1.52587890625e-05:  # 16 bits cancelled: a second piece (118 bits)
        t = r
        w = fn * _PIO2_2
        r = t - w
        w = fn * _PIO2_2T - ((t - r) - w)
        y0 = r - w
        if abs(y0) < abs(x) * 1.7763568394002505e-15:  # 49 bits: a third (151 bits)
            t = r
            w = fn * _PIO2_3
            r = t - w
            w = fn * _PIO2_3T - ((t - r) - w)
            y0 = r - w
    return y0, (r - y0) - w, int(fn) & 3


@njit(cache=True, inline="always")
def sincos(x):  # type: ignore[no-untyped-def]
    """``(sin x, cos x)``, each within 1 ulp (see above). Inlined, under the caller's flags."""
    if abs(x) <= _PIO4:
        return _ksin(x, 0.0), _kcos(x, 0.0)
    if not abs(x) <= _TRIG_FAST:  # also NaN and ±inf
        return math.sin(x), math.cos(x)
    r, t, q = _reduce(x)
    s, c = _ksin(r, t), _kcos(r, t)
    if q == 0:
        return s, c
    if q == 1:
        return c, -s
    if q == 2:
        return -s, -c
    return -c, s


@njit(cache=True, inline="always")
def sine(x):  # type: ignore[no-untyped-def]
    """``sin x``: :func:`sincos`'s first (inlined, the cosine's polynomial is dead code)."""
    return sincos(x)[0]


@njit(cache=True, inline="always")
def cosine(x):  # type: ignore[no-untyped-def]
    """``cos x``: :func:`sincos`'s second."""
    return sincos(x)[1]
