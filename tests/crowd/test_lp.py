"""The linear programs of ORCA (van den Berg et al. 2011 §5), case by case."""

from __future__ import annotations

import numpy as np

from pedvr.crowd.orca import linear_program1, linear_program2, linear_program3


def _lines(*rows: tuple[float, float, float, float]) -> np.ndarray:
    a = np.zeros((max(len(rows), 1) + 8, 4))
    for k, r in enumerate(rows):
        a[k] = r
    return a


def test_no_lines_inside_disc_keeps_preferred() -> None:
    fail, x, y = linear_program2(_lines(), 0, 2.0, 0.5, -0.3, False)
    assert fail == 0 and (x, y) == (0.5, -0.3)


def test_no_lines_outside_disc_clamps_to_max_speed() -> None:
    fail, x, y = linear_program2(_lines(), 0, 1.0, 3.0, 4.0, False)
    assert fail == 0
    np.testing.assert_allclose((x, y), (0.6, 0.8))


def test_single_line_projects_preferred_onto_it() -> None:
    # Permitted: left of direction (1, 0) through (0, 0.5), i.e. y >= 0.5.
    lines = _lines((0.0, 0.5, 1.0, 0.0))
    fail, x, y = linear_program2(lines, 1, 2.0, 0.3, -1.0, False)
    assert fail == 1
    np.testing.assert_allclose((x, y), (0.3, 0.5))


def test_satisfied_line_changes_nothing() -> None:
    lines = _lines((0.0, 0.5, 1.0, 0.0))
    _, x, y = linear_program2(lines, 1, 2.0, 0.3, 1.0, False)
    assert (x, y) == (0.3, 1.0)


def test_two_lines_optimum_at_their_corner() -> None:
    # y >= 0.5 and x <= -0.2 (left of direction (0, 1) through (-0.2, 0)).
    lines = _lines((0.0, 0.5, 1.0, 0.0), (-0.2, 0.0, 0.0, 1.0))
    fail, x, y = linear_program2(lines, 2, 2.0, 1.0, 0.0, False)
    assert fail == 2
    np.testing.assert_allclose((x, y), (-0.2, 0.5), atol=1e-12)


def test_line_outside_max_speed_disc_is_infeasible() -> None:
    # y >= 3 cannot be met inside the unit disc.
    lines = _lines((0.0, 3.0, 1.0, 0.0))
    ok, _, _ = linear_program1(lines, 0, 1.0, 0.0, 0.0, False)
    assert not ok
    fail, x, y = linear_program2(lines, 1, 1.0, 0.2, 0.1, False)
    assert fail == 0 and (x, y) == (0.2, 0.1)  # the optimum before the failing line


def test_parallel_opposite_lines_with_empty_overlap_fail() -> None:
    # y >= 0.5 and y <= 0.2: empty.
    lines = _lines((0.0, 0.5, 1.0, 0.0), (0.0, 0.2, -1.0, 0.0))
    fail, _, _ = linear_program2(lines, 2, 2.0, 0.0, 0.0, False)
    assert fail == 1


def test_direction_optimisation_takes_the_extreme() -> None:
    lines = _lines((0.0, 0.5, 1.0, 0.0))
    fail, x, y = linear_program2(lines, 1, 1.0, 0.0, -1.0, True)
    # Furthest along (0, -1) with y >= 0.5 inside the unit disc: on the line at the disc's edge.
    assert fail == 1
    assert abs(y - 0.5) < 1e-12 and abs(x * x + y * y - 1.0) < 1e-12


def test_dense_case_splits_the_violation_evenly() -> None:
    # Soft lines y >= 0.5 and y <= -0.5 conflict; LP3 minimises the largest
    # violation: y = 0 violates both by 0.5.
    lines = _lines((0.0, 0.5, 1.0, 0.0), (0.0, -0.5, -1.0, 0.0))
    proj = np.zeros_like(lines)
    fail, x, y = linear_program2(lines, 2, 2.0, 0.7, 0.0, False)
    assert fail == 1
    x, y = linear_program3(lines, 2, 0, fail, 2.0, x, y, proj)
    assert abs(y) < 1e-9


def test_dense_case_keeps_hard_lines() -> None:
    # Hard: x >= 1 (left of direction (0, -1) through (1, 0)).
    hard = (1.0, 0.0, 0.0, -1.0)
    lines = _lines(hard, (0.0, 0.5, 1.0, 0.0), (0.0, -0.5, -1.0, 0.0))
    proj = np.zeros_like(lines)
    fail, x, y = linear_program2(lines, 3, 2.0, 0.0, 0.0, False)
    assert fail == 2
    x, y = linear_program3(lines, 3, 1, fail, 2.0, x, y, proj)
    assert x >= 1.0 - 1e-9 and abs(y) < 1e-9
