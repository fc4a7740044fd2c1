"""Body motion people notice (issue 11): the walking figures against people's bands.

Each figure is measured on the posed bodies (forward kinematics and the gait state), the reference
adult (1.75 m) unless said otherwise, after the body has settled into its walk:

* 1.3–1.4 m/s: cadence 1.8–2.1 steps/s, steps 0.65–0.78 m (test_locomotion also checks heights
  1.55–1.95 m), double support about 20 % of the time, pelvis bob 4–5 cm;
* 1.8 m/s: bob 5–6 cm (it was 9.7 cm); 0.5 m/s: cadence about 1.5 steps/s (it sat at 1.3);
* planted knees straighten to near full extension (it never went below 12°);
* the first step from standing is shorter than a walking step (it was a 0.74 m lunge with a
  12 cm pelvis drop) and the steps after it settle into the walk without a lunge;
* side steps and back steps are short and taken without a crouch (one 0.5–0.7 m step with a
  7–10 cm crouch before).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.body._walk import Trace, bodies, drive, ramp

SETTLED = 4.0  # s: figures are taken after this


def _walk(v: float, seconds: float = 10.0, heights: np.ndarray | None = None) -> tuple[Trace, np.ndarray]:
    n = 1 if heights is None else len(heights)
    b = bodies(n, heights=heights)
    tr = Trace()
    drive(b, ramp(v, 0.0, n=n), lambda t: np.zeros(n), seconds, record=tr)
    st = np.concatenate(b.step_log)
    return tr, st


def _cadence(st: np.ndarray, row: int = 0) -> tuple[float, float]:
    mine = st[(st[:, 0] == row) & (st[:, 1] < 1.5)][6:]
    return float(1.0 / mine[:, 1].mean()), float(mine[:, 2].mean())


@pytest.fixture(scope="module")
def walks() -> dict[float, tuple[Trace, np.ndarray]]:
    return {v: _walk(v) for v in (0.5, 1.3, 1.35, 1.4, 1.8)}


@pytest.mark.parametrize("v", [1.3, 1.35, 1.4])
def test_normal_walking_stays_inside_the_human_bands(walks: dict[float, tuple[Trace, np.ndarray]],
                                                     v: float) -> None:
    tr, st = walks[v]
    cadence, length = _cadence(st)
    stride = 2.0 / cadence
    assert 1.8 <= cadence <= 2.1, cadence
    assert 0.65 <= length <= 0.78, length
    assert 0.17 <= tr.double_support(0, after=SETTLED) <= 0.23
    assert 0.04 <= tr.bob(0, after=SETTLED, period=stride) <= 0.05


def test_fast_walk_bobs_like_people_slow_walk_steps_like_people(
        walks: dict[float, tuple[Trace, np.ndarray]]) -> None:
    tr, st = walks[1.8]
    cadence, _ = _cadence(st)
    assert 0.05 <= tr.bob(0, after=SETTLED, period=2.0 / cadence) <= 0.06
    slow, _ = _cadence(walks[0.5][1])
    assert 1.4 <= slow <= 1.6, slow


def test_planted_knees_straighten(walks: dict[float, tuple[Trace, np.ndarray]]) -> None:
    for v in (1.3, 1.35, 1.4, 1.8):
        straightest = walks[v][0].stance_knee_min(0, after=SETTLED)
        assert straightest.size > 6
        assert np.percentile(straightest, 90) <= 5.0, (v, straightest)
    # standing at ease, the knees are all but straight: no crouch
    b = bodies(1)
    tr = Trace()
    drive(b, lambda t: np.zeros((1, 2)), lambda t: np.zeros(1), 1.0, record=tr)
    assert tr.arrays(0.5)["knee"].max() <= 8.0


@pytest.mark.parametrize("height", [1.55, 1.75, 1.95])
def test_first_step_from_standing_is_short_and_the_walk_settles_without_a_lunge(height: float) -> None:
    b = bodies(1, heights=np.array([height]))
    tr = Trace()
    drive(b, ramp(1.35, 0.0), lambda t: np.zeros(1), 6.0, record=tr)  # the default profile's acceleration
    steps = tr.landings(0, np.array([1.0, 0.0]))
    steady = float(np.median(steps[-6:]))
    assert 0.55 * steady <= steps[0] <= 0.8 * steady, (steps, steady)
    assert steps[1:].max() <= 1.1 * steady, (steps, steady)
    # the pelvis goes no lower while starting than in the steady walk's double support
    y = tr.arrays()["pelvis"][:, 0]
    start, walk = y[: round(2.0 / 0.0111)], tr.arrays(SETTLED)["pelvis"][:, 0]
    assert start.min() >= walk.min() - 0.005, (start.min(), walk.min())


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_side_steps_are_short_and_upright(side: float) -> None:
    b = bodies(1)
    tr = Trace()
    drive(b, lambda t: ramp(0.0, 0.5 * side)(t) if t < 3.0 else np.zeros((1, 2)), lambda t: np.zeros(1), 4.0,
          record=tr)
    a = tr.arrays()
    lateral = a["feet"][:, 0, :, 1]  # heading 0: sideways is 2D y
    separation = np.abs(lateral[:, 0] - lateral[:, 1])
    assert separation.max() <= 0.5, separation.max()
    moves = np.hypot(*tr.swings(0).T)
    assert moves.size >= 6 and moves.max() <= 0.35, moves  # each step moves a foot at most 35 cm
    assert b.state.pelvis_rest[0] - a["pelvis"][:, 0].min() <= 0.03  # no crouch


def test_back_steps_are_short_and_upright() -> None:
    b = bodies(1)
    tr = Trace()
    drive(b, lambda t: ramp(-0.45, 0.0)(t) if t < 3.0 else np.zeros((1, 2)), lambda t: np.zeros(1), 4.0,
          record=tr)
    moves = np.hypot(*tr.swings(0).T)
    assert moves.size >= 4 and moves.max() <= 0.7, moves  # a foot moves two step lengths
    steps = -tr.landings(0, np.array([1.0, 0.0]))
    assert steps.max() <= 0.35, steps
    assert b.state.pelvis_rest[0] - tr.arrays()["pelvis"][:, 0].min() <= 0.035
