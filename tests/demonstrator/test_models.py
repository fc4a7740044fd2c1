"""The coordination (§7) and engagement (§8) models as functions."""

from __future__ import annotations

import math

import pytest

from pedvr.demonstrator.coordination import (
    FORWARD_FOR,
    MAX_SHIFT,
    TRANSITION,
    WINDOW,
    braking_speed,
    choose_start,
    time_to_stop,
)
from pedvr.demonstrator.engagement import DECLINE, LEAD, MIN_SCALE, hold_schedule, observer_delay, shift_deg


def forward_for(psi: float, rate: float, t0: float, t: float) -> bool:
    """The arm swings forward at ``t`` and for FORWARD_FOR s after it."""
    return all(math.cos(psi + rate * (t + k * FORWARD_FOR / 4 - t0)) > -1e-9 for k in range(5))


def test_a_codirectional_nominal_start_is_kept() -> None:
    rate = 2 * math.pi / 1.1
    t_stop = 10.0
    psi_at_nominal = -0.5 * math.pi + 0.2  # just past the rearmost point at the nominal start
    now = 9.0
    psi = psi_at_nominal - rate * (t_stop - TRANSITION - now)
    s = choose_start(now, t_stop, psi=psi, rate=rate)
    assert s.how == "codirectional" and s.t == pytest.approx(t_stop - TRANSITION)


@pytest.mark.parametrize("offset", [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0])
def test_the_start_matches_the_swing_within_the_window(offset: float) -> None:
    rate = 2 * math.pi / 1.1
    now, t_stop = 8.5, 10.0
    s = choose_start(now, t_stop, psi=offset, rate=rate)
    assert WINDOW[0] - 1e-9 <= s.window <= WINDOW[1] + 1e-9
    assert abs(s.t - (t_stop - TRANSITION)) <= MAX_SHIFT + 1e-9
    if s.how != "nominal":
        assert forward_for(offset, rate, now, s.t)
        assert s.how == ("shortened" if s.t > t_stop - TRANSITION + 1e-9 else
                         "overridden" if s.t < t_stop - TRANSITION - 1e-9 else "codirectional")


def test_standing_still_uses_the_nominal_window() -> None:
    s = choose_start(0.0, 3.0, psi=1.0, rate=0.0)
    assert (s.t, s.window, s.how) == (3.0 - TRANSITION, TRANSITION, "nominal")


def test_braking_and_the_time_to_stop() -> None:
    assert braking_speed(0.05, arrive=0.1) == 0.0
    assert braking_speed(0.85, arrive=0.1) == pytest.approx(math.sqrt(2 * 1.0 * 0.8))
    far, near = (time_to_stop(d, speed=1.3, pref_speed=1.3, arrive=0.1) for d in (3.0, 1.0))
    assert far - near == pytest.approx(2.0 / 1.3)  # cruising
    turned = time_to_stop(1.0, speed=1.3, pref_speed=1.3, arrive=0.1, turn=math.pi / 2, turn_rate=3.0)
    assert turned - near == pytest.approx(math.pi / 6)


def test_the_observer_gaze_starts_earlier_the_larger_the_turn() -> None:
    """§8: Δt is negative when the observer is off the centre of view, more so the more the head turns."""
    assert observer_delay(0.0) == pytest.approx(-LEAD)
    assert observer_delay(90.0) < observer_delay(30.0) < observer_delay(0.0) < 0.0
    assert shift_deg((0, 1.6, 0), (1, 0.8, 0), (1, 1.6, 0)) == pytest.approx(math.degrees(math.atan2(0.8, 1)))


def test_gaze_durations_decline_over_repeated_demonstrations() -> None:
    def first_look(repeats: int) -> float:
        s = hold_schedule(0.0, 20.0, repeats)
        assert s[0] == (0.0, "observer") and [w for _, w in s[:4]] == ["observer", "target", "observer", "target"]
        return s[1][0] - s[0][0]

    looks = [first_look(n) for n in range(6)]
    assert all(b < a for a, b in zip(looks[:4], looks[1:5], strict=True))
    assert looks[1] == pytest.approx(looks[0] * DECLINE)
    assert looks[5] == pytest.approx(looks[0] * MIN_SCALE)  # never below the floor
