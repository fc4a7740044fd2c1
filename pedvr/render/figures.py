"""Agents without a body: default dims and the standing bind pose (no GL).

The renderer draws a crowd from the body layer's joint matrices
``(N, 26, 4, 4)`` (``sim.body.joint_matrices()``, DESIGN.md "body") through
skinned characters (:mod:`pedvr.render.bodymesh`). A renderer fed without a
body (hand-made snapshots in tests and tools) draws each agent standing in the
bind pose at its position and heading (:func:`standing_bones`), with dims
drawn from its id (:func:`default_dims`): there is no second animation path.
"""

from __future__ import annotations

import math

import numpy as np

from pedvr.body import JOINTS, rest_positions
from pedvr.body import skeleton as sk
from pedvr.render.crowd import _hash01
from pedvr.render.math3d import ground_to_world

REFERENCE_HEIGHT = sk.REFERENCE_HEIGHT  # m: the body layer's reference adult


def default_dims(ids: np.ndarray) -> np.ndarray:
    """Body dims ``(N, 4)`` (height, sex, build, scale) for agents that have no body, drawn from the id.

    Sex is female for half the ids; heights as the body layer draws them
    (men 1.76 ± 0.07 m, women 1.63 ± 0.065 m, here from a hashed normal),
    clipped to its range; build uniform.
    """
    ids = np.asarray(ids, np.int64)
    female = _hash01(ids, 1) < 0.5
    u1, u2 = np.maximum(_hash01(ids, 2), 1e-12), _hash01(ids, 3)
    z = np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * math.pi * u2)
    height = np.clip(np.where(female, 1.63 + 0.065 * z, 1.76 + 0.07 * z), *sk.HEIGHT_RANGE)
    dims = np.zeros((len(ids), 4))
    dims[:, sk.DIM_HEIGHT], dims[:, sk.DIM_SEX] = height, female.astype(np.float64)
    dims[:, sk.DIM_BUILD], dims[:, sk.DIM_SCALE] = _hash01(ids, 4), height / REFERENCE_HEIGHT
    return dims


def standing_bones(pos: np.ndarray, heading: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """World joint matrices ``(N, 26, 4, 4)`` float32 of people standing in the bind pose.

    Agent ``i`` stands at 2D ``pos[i]`` facing 2D ``heading[i]`` (the body
    layer's convention: a rotation about +Y by π/2 − θ turns its +Z forward
    onto 3D ``(cos θ, 0, sin θ)``); its eyes look straight ahead.
    """
    pos = np.asarray(pos, np.float64).reshape(-1, 2)
    n = pos.shape[0]
    a = math.pi / 2 - np.asarray(heading, np.float64).reshape(n)
    c, s = np.cos(a), np.sin(a)
    rot = np.zeros((n, 3, 3))
    rot[:, 0, 0], rot[:, 0, 2], rot[:, 1, 1], rot[:, 2, 0], rot[:, 2, 2] = c, s, 1.0, -s, c
    rest = rest_positions(dims)[:, : len(JOINTS)]
    out = np.zeros((n, len(JOINTS), 4, 4))
    out[:, :, :3, :3] = rot[:, None]
    out[:, :, :3, 3] = np.einsum("nij,nkj->nki", rot, rest) + ground_to_world(pos)[:, None, :]
    out[:, :, 3, 3] = 1.0
    return out.astype(np.float32)
