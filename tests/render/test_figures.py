"""The body-layer skeleton's segments, the standing fallback and per-agent looks (pure numpy)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body import JOINTS
from pedvr.body import skeleton as sk
from pedvr.render.figures import (
    BODY,
    PUPIL,
    Segment,
    Skeleton,
    agent_looks,
    default_dims,
    skeleton_mesh,
    standing_bones,
)
from tests.render.conftest import posed


def _mesh_world(bones: np.ndarray, scale: float) -> np.ndarray:
    """World positions of agent 0's mesh vertices, joint frames scaled as the renderer does."""
    b = bones[0].astype(np.float64).copy()
    b[:, :3, :3] *= scale
    mesh = skeleton_mesh(BODY)
    return np.einsum("vij,vj->vi", b[mesh["bone"]], np.c_[mesh["pos"], np.ones(len(mesh))])[:, :3]


def test_the_skeleton_is_the_body_layers() -> None:
    assert BODY.names == tuple(JOINTS) and BODY.joints == 26
    assert {BODY.names[s.bone] for s in BODY.segments if s.slot == PUPIL} == {"LEye", "REye"}


@pytest.mark.parametrize("height", [1.58, 1.75, 1.9])
def test_a_posed_body_stands_on_the_floor_and_is_as_tall_as_its_dims(height: float) -> None:
    snap, body = posed([[1.0, 2.0]], [0.7], reference=True)
    dims = body.state.dims.copy()
    dims[:, sk.DIM_HEIGHT], dims[:, sk.DIM_SCALE] = height, height / sk.REFERENCE_HEIGHT
    for bones in (snap.bones, standing_bones(snap.pos, snap.heading, dims)):
        assert bones is not None
        scale = 1.0 if bones is snap.bones else height / sk.REFERENCE_HEIGHT
        world = _mesh_world(bones, scale)
        target = 1.75 if bones is snap.bones else height
        assert world[:, 1].min() == pytest.approx(0.0, abs=0.03)
        assert world[:, 1].max() == pytest.approx(target, abs=0.04)
        # Centred on the agent, facing its heading: the nose is ahead of the pelvis.
        assert world[:, [0, 2]].mean(axis=0) == pytest.approx([1.0, 2.0], abs=0.08)


def test_standing_bones_face_the_heading_with_the_left_on_the_left() -> None:
    b = standing_bones(np.array([[1.0, 2.0]]), np.array([0.7]), default_dims(np.array([5])))
    assert b.shape == (1, 26, 4, 4) and b.dtype == np.float32
    fwd = b[0, 0, :3, :3] @ [0, 0, 1]
    assert fwd == pytest.approx([math.cos(0.7), 0.0, math.sin(0.7)], abs=1e-6)
    left = b[0, JOINTS.index("LHip"), :3, 3] - b[0, 0, :3, 3]
    assert np.dot(left, b[0, 0, :3, :3] @ [1, 0, 0]) > 0.05  # +X of the body frame is its left


def test_looks_are_stable_per_id_and_varied_across_ids() -> None:
    pal, h = agent_looks(np.arange(200))
    pal2, h2 = agent_looks(np.arange(200))
    assert np.array_equal(pal, pal2) and np.array_equal(h, h2)
    assert 1.55 <= h.min() and h.max() <= 1.92 and h.std() > 0.05
    assert len({tuple(np.round(c, 3)) for c in pal[:, 1]}) >= 8  # many shirt colours


def test_skeleton_validates_its_parents_and_segments() -> None:
    with pytest.raises(ValueError, match="parent 1 must come before it"):
        Skeleton(names=("a", "b"), parents=(-1, 1), segments=())
    with pytest.raises(ValueError, match="segment shape 'cone'"):
        Skeleton(names=("a",), parents=(-1,), segments=(Segment(0, "cone", (0, 0, 0), (1, 1, 1), 0),))
