"""The touchdown skid (issue 11): a heel that comes within 2 mm of the floor must not slide on.

An independent oracle reads only the posed heels and toe tips: from the first frame a point is
within 2 mm of the floor, its horizontal travel until it leaves that band is its slide. On main the
landing target was re-planned with the time to touchdown clamped to 0 on the landing frame, so the
heel, 0.4–1 mm above the floor the frame before, landed 10–15 mm further on (1.2 m/s), and the
meter, which anchored at the landing frame, read exactly 0.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from pedvr.body import skeleton as sk
from tests.body._walk import bodies, drive

POINTS = [sk.L_HEEL, sk.L_TOE_TIP, sk.R_HEEL, sk.R_TOE_TIP]
CONTACT_HEIGHT = 0.002  # m: within this of the floor a heel or toe tip touches it (issue 11)


def oracle_slide(track: np.ndarray) -> float:
    """Largest slide of any point ``track (F, P, 3)`` while within CONTACT_HEIGHT of the floor."""
    worst = 0.0
    for p in range(track.shape[1]):
        down = np.concatenate([track[:, p, 1] <= CONTACT_HEIGHT, [False]])
        start = None
        for k, d in enumerate(down):
            if d and start is None:
                start = k
            elif not d and start is not None:
                seg = track[start:k, p]
                worst = max(worst, float(np.hypot(seg[:, 0] - seg[0, 0], seg[:, 2] - seg[0, 2]).max()))
                start = None
    return worst


CASES: dict[str, tuple[Callable[[float], np.ndarray], Callable[[float], np.ndarray]]] = {
    "straight 1.2 m/s": (lambda t: np.array([[1.2, 0.0]]), lambda t: np.zeros(1)),
    "speeding up": (lambda t: np.array([[min(1.6, 0.2 + 1.5 * t), 0.0]]), lambda t: np.zeros(1)),
    "speed jumps": (lambda t: np.array([[0.6 + 0.8 * (np.sin(2.3 * t) > 0), 0.0]]), lambda t: np.zeros(1)),
    "curve": (lambda t: 1.3 * np.array([[np.cos(0.6 * t), np.sin(0.6 * t)]]), lambda t: np.array([0.6 * t])),
}


@pytest.mark.parametrize("case", list(CASES))
def test_heels_do_not_skid_at_touchdown_and_the_meter_sees_what_the_oracle_sees(case: str) -> None:
    velocity, heading = CASES[case]
    b = bodies(1)
    track: list[np.ndarray] = []
    drive(b, velocity, heading, 8.0, record=lambda bb, t: track.append(bb.state.world_pos[0, POINTS].copy()))
    truth = oracle_slide(np.asarray(track))
    assert truth <= 0.001, f"{case}: a heel or toe slid {truth * 1e3:.1f} mm within 2 mm of the floor"
    # the meter anchors at the same first frame within 2 mm, so it reads the same slide
    assert b.skate.slides().max() == pytest.approx(truth, abs=1e-9)
