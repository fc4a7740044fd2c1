"""The procedural skeleton and per-agent looks (pure numpy)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.render.figures import (
    EYE_YAW_LIMIT,
    NOMINAL_HEIGHT,
    PROCEDURAL,
    Segment,
    Skeleton,
    agent_looks,
    procedural_pose,
    skeleton_mesh,
)


def pose(**kw: object) -> np.ndarray:
    args: dict[str, object] = {
        "pos": np.array([[1.0, 2.0]]),
        "heading": np.array([0.7]),
        "speed": np.zeros(1),
        "height": np.array([1.7]),
        "phase": np.zeros(1),
    }
    args.update(kw)
    return procedural_pose(**args)  # type: ignore[arg-type]


def test_bones_stand_on_the_floor_at_the_agent_facing_its_heading() -> None:
    b = pose()
    assert b.shape == (1, PROCEDURAL.joints, 4, 4) and b.dtype == np.float32
    root = b[0, 0]
    assert root[:3, 3] == pytest.approx([1.0, 0.0, 2.0])
    fwd = root[:3, :3] @ [1, 0, 0] / np.linalg.norm(root[:3, 0])
    assert fwd == pytest.approx([math.cos(0.7), 0.0, math.sin(0.7)], abs=1e-6)
    # The lowest vertex (soles) touches the floor; the top of the head is the body height.
    mesh = skeleton_mesh(PROCEDURAL)
    world = np.einsum("vij,vj->vi", b[0][mesh["bone"]], np.c_[mesh["pos"], np.ones(len(mesh))])
    assert world[:, 1].min() == pytest.approx(0.0, abs=0.02)
    assert world[:, 1].max() == pytest.approx(1.7, abs=0.03)


def test_eyes_turn_toward_the_gaze_target_and_stop_at_their_limit() -> None:
    head = PROCEDURAL.index("eye_l")
    # Heading 0 (2D +x); a target ahead and to the side at eye height.
    for side in (0.3, -0.3):
        target = np.array([[4.0, 1.6, 2.0 + side * 4]])
        b = pose(heading=np.zeros(1), gaze_target=target)
        eye = b[0, head]
        look = eye[:3, :3] @ [1, 0, 0]
        to_target = target[0] - eye[:3, 3]
        angle = math.acos(np.dot(look, to_target) / np.linalg.norm(look) / np.linalg.norm(to_target))
        assert angle < math.radians(3)
    behind = pose(heading=np.zeros(1), gaze_target=np.array([[-5.0, 1.6, 2.0]]))
    look = behind[0, head, :3, :3] @ [1, 0, 0]
    assert look[0] > 0  # cannot look behind: head and eyes stop at their limits
    assert math.atan2(abs(look[2]), look[0]) <= math.radians(70 * 0.7) + EYE_YAW_LIMIT + 1e-6


def test_walking_swings_the_legs_and_standing_does_not() -> None:
    knee = PROCEDURAL.index("shin_l")
    still = [pose(phase=np.array([p]))[0, knee, :3, 3] for p in (0.0, 1.5)]
    walk = [pose(phase=np.array([p]), speed=np.array([1.3]))[0, knee, :3, 3] for p in (0.0, 1.5)]
    assert np.allclose(still[0], still[1])
    assert np.linalg.norm(walk[0] - walk[1]) > 0.05


def test_looks_are_stable_per_id_and_varied_across_ids() -> None:
    pal, h = agent_looks(np.arange(200))
    pal2, h2 = agent_looks(np.arange(200))
    assert np.array_equal(pal, pal2) and np.array_equal(h, h2)
    assert 1.55 <= h.min() and h.max() <= 1.92 and h.std() > 0.05
    assert len({tuple(np.round(c, 3)) for c in pal[:, 1]}) >= 8  # many shirt colours
    assert NOMINAL_HEIGHT == pytest.approx(1.76)


def test_skeleton_validates_its_parents_and_segments() -> None:
    with pytest.raises(ValueError, match="parent 1 must come before it"):
        Skeleton(names=("a", "b"), parents=(-1, 1), segments=())
    with pytest.raises(ValueError, match="segment shape 'cone'"):
        Skeleton(names=("a",), parents=(-1,), segments=(Segment(0, "cone", (0, 0, 0), (1, 1, 1), 0),))
