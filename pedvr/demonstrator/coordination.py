"""Locomotion–action coordination (Huang & Kallmann §7, Figs. 15–16).

"We start by using a transition window of 0.58 seconds ... The window tells
how early, before finishing the locomotion, the action should start to be
executed. The action will start gradually taking control over the
upper-body and will achieve full control when the locomotion stops." The
window is adjusted so the arm swing never reverses suddenly, and stays
"between 1/3 to 4/3 seconds".

pedvr's walk swings the arms procedurally (``FullBody.arm_swing``: the
shoulder's flexion goes as ``sin ψ``), and the action takes the arm over
through the reach choreographer, whose weight rises linearly over 0.5 s
(:mod:`pedvr.body.coordinator`): about one forward swing of the arm at a
walk. So the action is started where the pointing arm *begins* a forward
swing (ψ ≡ −π/2, the arm at its rearmost): the arm then keeps moving forward
while the action takes it over, which is the codirectional case of Fig. 15.
The start nearest the nominal window that stays inside the allowed one is
chosen:

* later than nominal (the final backward swing is not started: Fig. 15 (3),
  "shortened");
* earlier than nominal (the previous forward swing carries on into the
  action: Fig. 15 (4), "overridden");

and "the one showing better consistency" is read as the smaller change of
the window. With no swing to match (standing, or no forward swing begins
inside the allowed window) the nominal start is used.

When the feet will stop is predicted from the distance left to the
placement (:func:`time_to_stop`): the demonstrator brakes at a constant
:data:`BRAKE` over its last steps (:func:`braking_speed`, which the
demonstration imposes through the speed scale) and the gait then lands its
last step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

TRANSITION = 0.58  # s: the observed average window (§7)
WINDOW = (1.0 / 3.0, 4.0 / 3.0)  # s: the window's allowed range after adjustment
SLOWING_DIST = 0.8  # m: pedvr.sim slows an agent linearly inside this distance of its last waypoint
BRAKE = 1.0  # m/s²: the demonstrator's deceleration over its last steps
MAX_SHIFT = 0.3  # s: the window moves at most this far from the nominal one to match the swing
FORWARD_FOR = 0.15  # s the arm must go on swinging forward after the action starts
# s from the arrival to the feet at rest: the step under way lands and a squaring step may follow
# (0.62 to 1.19 s, mean 0.9 s, over nine approaches measured on pedvr's gait)
LAST_STEP = 0.9


@dataclass(frozen=True)
class Start:
    """When the action starts (simulation time, s), the window it leaves before the feet stop,
    and how the swing was matched: ``nominal``, ``codirectional``, ``shortened``, ``overridden``."""

    t: float
    window: float
    how: str


def braking_speed(distance: float, *, arrive: float, brake: float = BRAKE) -> float:
    """The speed (m/s) that stops a walker at its goal with constant deceleration ``brake``: people
    slow down over their last steps, not by creeping up on the spot."""
    return math.sqrt(2.0 * brake * max(distance - 0.5 * arrive, 0.0))


def time_to_stop(distance: float, *, speed: float, pref_speed: float, arrive: float,
                 brake: float = BRAKE, turn: float = 0.0, turn_rate: float = 3.0) -> float:
    """Seconds until the feet stop, for a walker ``distance`` m (along its path) from its goal at
    ``speed`` m/s, cruising at ``pref_speed`` and braking at ``brake`` m/s² (:func:`braking_speed`),
    arriving within ``arrive`` m, then turning on the spot by ``turn`` rad at ``turn_rate`` rad/s;
    plus :data:`LAST_STEP` for the feet to come to rest."""
    v = max(min(max(speed, 0.5 * pref_speed), pref_speed), 1e-3)
    d = max(distance - 0.5 * arrive, 0.0)
    d_brake = v * v / (2.0 * brake)
    if d > d_brake:
        t = (d - d_brake) / v + v / brake
    else:
        t = math.sqrt(2.0 * d / brake)
    return t + max(turn, 0.0) / max(turn_rate, 1e-3) + LAST_STEP


def choose_start(now: float, t_stop: float, *, psi: float, rate: float, nominal: float = TRANSITION,
                 window: tuple[float, float] = WINDOW, max_shift: float = MAX_SHIFT) -> Start:
    """The action's start for feet that stop at ``t_stop``, the arm's swing at ``now`` being
    ``psi`` advancing at ``rate`` rad/s (module docstring).

    A start is codirectional when the arm swings forward then and goes on doing so for at least
    :data:`FORWARD_FOR` s (``cos ψ > 0`` over that time). The nominal start is kept if it is;
    otherwise the nearest codirectional start inside ``window``: later ("shortened": the final
    backward swing is cut short) or earlier ("overridden": the previous forward swing carries
    the arm into the action), at most ``max_shift`` s from the nominal one. Without a swing, or
    without such a start, the nominal start.
    """
    t_nom = t_stop - nominal
    if rate <= 1e-6:
        return Start(t_nom, nominal, "nominal")
    lo, hi = max(t_stop - window[1], t_nom - max_shift), min(t_stop - window[0], t_nom + max_shift)
    # codirectional starts: psi(t) in [-pi/2, pi/2 - rate*FORWARD_FOR] (mod 2pi)
    span = math.pi - rate * FORWARD_FOR
    if span <= 0.0:
        return Start(t_nom, nominal, "nominal")
    period = 2.0 * math.pi / rate
    first = now + ((-0.5 * math.pi - psi) % (2.0 * math.pi)) / rate  # next time psi = -pi/2
    best: tuple[float, float] | None = None  # (|t - t_nom|, t)
    k0 = math.floor((lo - first) / period) - 1
    for k in range(k0, k0 + int((hi - lo) / period) + 4):
        a = first + k * period
        b = a + span / rate
        t = min(max(t_nom, a, lo), b, hi)  # the point of [a, b] ∩ [lo, hi] nearest the nominal
        if a - 1e-9 <= t <= b + 1e-9 and lo - 1e-9 <= t <= hi + 1e-9:
            if best is None or abs(t - t_nom) < best[0]:
                best = (abs(t - t_nom), t)
    if best is None:
        return Start(t_nom, nominal, "nominal")
    t = best[1]
    how = "codirectional" if best[0] < 1e-9 else "shortened" if t > t_nom else "overridden"
    return Start(t, t_stop - t, how)
