"""Parallel kernels and their serial twins give the same bytes; the kernels' shared helpers give
the bytes of what they replaced."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from pedvr.body.quat import FASTMATH
from pedvr.crowd import contact, orca
from pedvr.crowd.state import N_LIMITS, CrowdState
from pedvr.crowd.steering import Steering
from pedvr.kernels import SERIAL_BUDGET_S, Chooser, cosine, sincos, sine, wrap_pi
from pedvr.scene.config import SteeringParams
from pedvr.world.obstacles import ObstacleSet


def crowd(n: int, seed: int) -> CrowdState:
    rng = np.random.default_rng(seed)
    side = np.sqrt(n) * 1.2
    g = np.stack(np.meshgrid(np.arange(int(np.ceil(np.sqrt(n)))), np.arange(int(np.ceil(np.sqrt(n))))), -1)
    pos = g.reshape(-1, 2)[:n] * 1.2 - side / 2 + rng.uniform(-0.2, 0.2, (n, 2))
    s = CrowdState.empty()
    s.append(CrowdState(
        ids=np.arange(n), pos=pos, vel=rng.uniform(-1, 1, (n, 2)), pref_vel=rng.uniform(-1.3, 1.3, (n, 2)),
        heading=rng.uniform(-np.pi, np.pi, n), pref_heading=np.zeros(n), radius=np.full(n, 0.25),
        pref_speed=np.full(n, 1.3), max_speed=np.full(n, 1.6), responsibility=np.full(n, 1.0),
        is_user=np.zeros(n, np.bool_), limits=np.tile([1.5, 2.5, 3.0, 1.6, 0.5, 0.6], (n, 1)).reshape(n, N_LIMITS)))
    return s


def _force(monkeypatch: pytest.MonkeyPatch, chooser: Chooser, parallel: bool) -> None:
    monkeypatch.setattr(chooser, "forced", parallel)


@pytest.mark.parametrize("coupled", [False, True])
def test_serial_twin_equals_parallel(coupled: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    state = crowd(900, seed=1)
    steer = Steering(SteeringParams(), ObstacleSet.empty(), coupled=coupled)
    _force(monkeypatch, orca.orca_kernel.chooser, True)
    par = steer.compute_velocities(state, 1 / 90).copy()
    _force(monkeypatch, orca.orca_kernel.chooser, False)
    ser = steer.compute_velocities(state, 1 / 90)
    assert par.tobytes() == ser.tobytes()


def test_contact_pass_twins_give_the_same_bytes(monkeypatch: pytest.MonkeyPatch) -> None:
    """The contact pass (Verlet lists, fused Jacobi iterations) runs serial or parallel as its
    measured cost says; both give the same positions, bit for bit."""
    rng = np.random.default_rng(3)
    n = 900
    pos = rng.uniform(0.0, 14.0, (n, 2))  # heavily overlapping: many iterations, list rebuilds
    radius = np.full(n, 0.25)
    is_user = np.zeros(n, np.bool_)
    is_user[0] = True
    box = ObstacleSet.from_polygons([np.array([[5.0, 5.0], [8.0, 5.0], [8.0, 8.0], [5.0, 8.0]])])
    steer = Steering(SteeringParams(), box, coupled=False)
    out = {}
    for par in (True, False):
        _force(monkeypatch, contact._CHOOSER, par)
        out[par] = steer.resolve_contacts(pos, radius, is_user)
    assert out[True].tobytes() == out[False].tobytes()
    assert len(contact.overlapping_pairs(out[True], radius, 0.01)) == 0


def test_chooser_keeps_a_kernel_that_fits_the_budget_on_one_thread() -> None:
    """Issue 12: a kernel whose serial call fits SERIAL_BUDGET_S never opens a parallel region,
    however much cheaper parallel would be: its step time does not depend on another core."""
    c = Chooser()
    assert c.choose(10) is False  # tiny: always serial, nothing recorded
    assert c.choose(1000) is False  # nothing measured: serial first, to measure it
    call = 0.5 * SERIAL_BUDGET_S
    picks = []
    for _ in range(500):
        par = c.choose(1000)
        picks.append(par)
        c.record(par, 1000, call / 4 if par else call)
    assert not any(picks) and c.calls == [500, 0]
    c.record(False, 1000, 40 * SERIAL_BUDGET_S)  # the crowd grew (or the core got busy): over budget
    assert c.choose(1000) is True  # parallel is tried ...
    c.record(True, 1000, 80 * SERIAL_BUDGET_S)  # ... and loses (a loaded machine)
    picks = []
    for _ in range(40):
        par = c.choose(1000)
        picks.append(par)
        c.record(par, 1000, 80 * SERIAL_BUDGET_S if par else 0.5 * SERIAL_BUDGET_S)
    # the serial calls fit again: once their average is back under the budget (a dozen calls),
    # one thread, and no more tries
    assert sum(picks) <= 2 and not any(picks[15:])


def test_chooser_takes_the_cheaper_twin_over_the_budget_and_backs_off() -> None:
    c = Chooser()
    slow = 2 * SERIAL_BUDGET_S  # a serial call over the budget
    assert c.choose(1000) is False
    c.record(False, 1000, slow)
    assert c.choose(1000) is True  # over the budget, parallel not measured: try it
    picks = []
    for _ in range(200):
        par = c.choose(1000)
        picks.append(par)
        c.record(par, 1000, 4 * slow if par else slow)  # parallel 4x slower (a loaded machine)
    assert picks[-1] is False and sum(picks[-100:]) <= 4  # serial, trying parallel rarely
    assert c.gap > 8  # each lost try doubles the wait before the next
    for _ in range(300):  # the machine gets quiet: parallel is 2x faster when tried
        par = c.choose(1000)
        c.record(par, 1000, slow / 2 if par else slow)
    assert c.choose(1000) is True


def test_one_slow_call_does_not_lock_the_chooser_onto_the_slower_twin() -> None:
    """A hiccup (one parallel call 20x slow, a worker descheduled) tips the average to serial;
    parallel is re-tried within EXPLORE_FIRST calls, not after the backed-off gap, and kept."""
    from pedvr.kernels import EXPLORE_FIRST

    c = Chooser()
    slow = 2 * SERIAL_BUDGET_S
    for _ in range(3000):  # a quiet machine: parallel 2x faster; the serial tries back off
        par = c.choose(1000)
        c.record(par, 1000, slow / 2 if par else slow)
    assert c.gap >= 1024 and c.choose(1000) is True
    c.record(True, 1000, 10 * slow)  # the hiccup
    picks = []
    for _ in range(4 * EXPLORE_FIRST):
        par = c.choose(1000)
        picks.append(par)
        c.record(par, 1000, slow / 2 if par else slow)
    assert picks[0] is False  # the hiccup made serial look cheaper ...
    assert picks[EXPLORE_FIRST - 1] is True  # ... until parallel was re-tried, soon,
    assert sum(picks[EXPLORE_FIRST:]) >= len(picks[EXPLORE_FIRST:]) - 3  # and kept (serial tried back off again)


def test_a_row_function_that_allocates_does_not_compile() -> None:
    """row_njit compiles without numba's runtime (no reference counting): a function that would
    allocate an array is refused when it is compiled, not run with memory nothing owns."""
    import numba

    from pedvr.kernels import row_njit

    def grows(n):  # type: ignore[no-untyped-def]
        return np.zeros(n).sum()

    def sums(a):  # type: ignore[no-untyped-def]
        s = 0.0
        for x in a[1:]:  # a view of an argument: no allocation, fine
            s += x
        return s

    with pytest.raises(numba.core.errors.TypingError):
        row_njit()(grows)(3)
    assert row_njit()(sums)(np.arange(4.0)) == 6.0


@pytest.mark.parametrize("fastmath", [False, FASTMATH, {"nsz", "arcp", "contract", "afn"}])
def test_wrap_pi_is_the_modulo_bit_for_bit(fastmath: object) -> None:
    """``wrap_pi`` is the modulo expression it replaced, bit for bit, under each set of fastmath
    flags the kernels compile it with (issue 27: the same bytes, without fmod)."""
    @njit(fastmath=fastmath)
    def new(a, out):  # type: ignore[no-untyped-def]
        for i in range(a.shape[0]):
            out[i] = wrap_pi(a[i])

    @njit(fastmath=fastmath)
    def old(a, out):  # type: ignore[no-untyped-def]
        for i in range(a.shape[0]):
            out[i] = (a[i] + math.pi) % (2.0 * math.pi) - math.pi

    rng = np.random.default_rng(1)
    pi = math.pi
    edges = [0.0, -0.0, pi, -pi, 2 * pi, -2 * pi, 3 * pi, -3 * pi, 1e-300, -1e-300, 5e-324, -5e-324, 1e10, -1e10]
    edges += [float(np.nextafter(x, t)) for x in (pi, -pi, 3 * pi, -3 * pi) for t in (-10.0, 10.0)]
    a = np.concatenate([edges, rng.uniform(-10.0, 10.0, 200_000), rng.normal(0.0, 1e-3, 100_000),
                        rng.integers(-5, 5, 20_000) * pi + rng.normal(0.0, 1e-15, 20_000)])
    got, want = np.empty_like(a), np.empty_like(a)
    new(a, got)
    old(a, want)
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))


@pytest.mark.parametrize("fastmath", [False, FASTMATH])
def test_sine_and_cosine_are_within_one_ulp_of_libm(fastmath: object) -> None:
    """The pose kernels' ``sincos``, ``sine`` and ``cosine`` (fdlibm's polynomials after a
    reduction by π/2) against glibc's: within 1 ulp everywhere (and at zero exact), on the
    quadrant boundaries, beyond the fast range, and NaN for NaN and ±inf."""
    @njit(fastmath=fastmath)
    def ours(a, out):  # type: ignore[no-untyped-def]
        for i in range(a.shape[0]):
            s, c = sincos(a[i])
            out[i, 0], out[i, 1] = s, c
            out[i, 2], out[i, 3] = sine(a[i]), cosine(a[i])

    rng = np.random.default_rng(3)
    pi = math.pi
    edges = [0.0, -0.0, 1e-300, -5e-324, 1e5, -1e5, 1.5e5, 1e12, -1e12]
    edges += [float(np.nextafter(k * pi / 4, t)) for k in range(-12, 13) for t in (-10.0, 10.0)]
    a = np.concatenate([edges, rng.uniform(-0.8, 0.8, 200_000), rng.uniform(-50.0, 50.0, 200_000),
                        rng.integers(-64, 64, 20_000) * (pi / 2) + rng.normal(0.0, 1e-9, 20_000)])
    out = np.empty((a.size, 4))
    ours(a, out)
    want_s, want_c = np.sin(a), np.cos(a)
    for k, want in ((0, want_s), (1, want_c), (2, want_s), (3, want_c)):
        err = np.abs(out[:, k] - want) / np.spacing(np.abs(want))
        assert err.max() <= 1.0, (k, a[np.argmax(err)])
    assert out[0, 0] == 0.0 and out[0, 1] == 1.0 and out[0, 3] == 1.0
    bad = np.empty((3, 4))
    ours(np.array([np.nan, np.inf, -np.inf]), bad)
    if fastmath is False:  # under nnan / ninf the compiler may assume neither comes
        assert np.isnan(bad).all()
