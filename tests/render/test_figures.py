"""The standing fallback for agents without a body, and default dims (pure numpy)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.body import JOINTS
from pedvr.body import skeleton as sk
from pedvr.render.figures import default_dims, standing_bones
from tests.render.conftest import posed
from tests.render.test_characters import skinned_world


@pytest.mark.parametrize("height", [1.58, 1.75, 1.9])
def test_a_posed_body_stands_on_the_floor_and_is_as_tall_as_its_dims(height: float) -> None:
    snap, body = posed([[1.0, 2.0]], [0.7], reference=True)
    dims = body.state.dims.copy()
    dims[:, sk.DIM_HEIGHT], dims[:, sk.DIM_SCALE] = height, height / sk.REFERENCE_HEIGHT
    for bones in (snap.bones, standing_bones(snap.pos, snap.heading, dims)):
        assert bones is not None
        d = body.state.dims if bones is snap.bones else dims
        world = skinned_world(bones[0], d[0])
        target = 1.75 if bones is snap.bones else height
        assert world[:, 1].min() == pytest.approx(0.0, abs=0.01)
        assert world[:, 1].max() == pytest.approx(target, abs=0.04 * target / 1.75)
        # Centred on the agent, facing its heading: the nose is ahead of the pelvis.
        assert world[:, [0, 2]].mean(axis=0) == pytest.approx([1.0, 2.0], abs=0.08)


def test_standing_bones_face_the_heading_with_the_left_on_the_left() -> None:
    b = standing_bones(np.array([[1.0, 2.0]]), np.array([0.7]), default_dims(np.array([5])))
    assert b.shape == (1, 26, 4, 4) and b.dtype == np.float32
    fwd = b[0, 0, :3, :3] @ [0, 0, 1]
    assert fwd == pytest.approx([math.cos(0.7), 0.0, math.sin(0.7)], abs=1e-6)
    left = b[0, JOINTS.index("LHip"), :3, 3] - b[0, 0, :3, 3]
    assert np.dot(left, b[0, 0, :3, :3] @ [1, 0, 0]) > 0.05  # +X of the body frame is its left


def test_default_dims_are_drawn_from_the_id_like_the_body_layers() -> None:
    d = default_dims(np.arange(400))
    assert np.array_equal(d, default_dims(np.arange(400)))
    female = d[:, sk.DIM_SEX] == 1.0
    assert 0.4 < female.mean() < 0.6
    assert d[female, 0].mean() == pytest.approx(1.63, abs=0.02) and d[~female, 0].mean() == pytest.approx(1.76, abs=0.02)
    assert np.allclose(d[:, sk.DIM_SCALE], d[:, sk.DIM_HEIGHT] / sk.REFERENCE_HEIGHT)
