"""Person-shaped figures on the body layer's 26-joint skeleton; per-agent looks; a standing fallback.

The renderer draws a crowd from two arrays: bone matrices ``(N, 26, 4, 4)``
(joint frame to world, per agent and joint; ``sim.body.joint_matrices()``,
DESIGN.md "body") and a palette ``(N, 4, 3)`` (skin, top, trousers,
hair/shoes; linear RGB). :data:`BODY` says which segments (boxes and
ellipsoids shaped like a head, torso, limbs, shoes, eyes with pupils) hang on
which joint; the mesh of all segments is drawn instanced, one draw call for
the whole crowd (DESIGN.md "render").

Segments are sized for the body layer's 1.75 m reference adult in each
joint's own frame (the bind pose has identity rotations, so joint frames share
the body frame's axes: **+Y up, +Z forward, +X the character's left**); the
renderer scales each agent's joint rotations by its ``dims`` scale
(height / 1.75), so a shorter person has a smaller head and thinner limbs as
well as shorter bones. Eye segments hang on ``LEye``/``REye`` with the pupil
on their local +Z, so the pupils show where the body's gaze controller aims.

A renderer fed without a body (hand-made snapshots in tests and tools) draws
each agent standing in the bind pose at its position and heading
(:func:`standing_bones`): there is no second animation path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pedvr.body import JOINTS, PARENTS, rest_positions
from pedvr.render.math3d import ground_to_world

# Colour slots of a segment; 0-3 vary per agent (the palette), 4-5 are fixed in the shader.
SKIN, TOP, TROUSERS, HAIR, EYE_WHITE, PUPIL = range(6)
REFERENCE_HEIGHT = 1.75  # m: the body layer's reference adult, for whom the segments are sized


@dataclass(frozen=True)
class Segment:
    """A rigid body part: a ``box`` or ``ellipsoid`` of full ``size`` at ``center`` in its bone's frame."""

    bone: int
    shape: str
    center: tuple[float, float, float]
    size: tuple[float, float, float]
    slot: int


@dataclass(frozen=True)
class Skeleton:
    """Joint names, parents (-1 for the root; parents come before children) and the segments."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        if len(self.names) != len(self.parents):
            raise ValueError("names and parents differ in length")
        for j, p in enumerate(self.parents):
            if p >= j:
                raise ValueError(f"joint {self.names[j]!r}: parent {p} must come before it")
        for s in self.segments:
            if not 0 <= s.bone < len(self.names):
                raise ValueError(f"segment on bone {s.bone}: no such joint")
            if s.shape not in ("box", "ellipsoid"):
                raise ValueError(f"segment shape {s.shape!r}: expected box or ellipsoid")

    @property
    def joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        return self.names.index(name)


def _body_skeleton() -> Skeleton:
    """Segments on the body layer's joints (reference adult: hips 0.93 m, eyes 1.64 m, head top 1.75 m)."""
    names = tuple(JOINTS)
    parents = tuple(int(p) for p in PARENTS[: len(names)])
    j = {n: i for i, n in enumerate(names)}
    segs = [
        Segment(j["Pelvis"], "box", (0.0, -0.03, -0.005), (0.32, 0.2, 0.2), TROUSERS),
        Segment(j["Spine1"], "box", (0.0, 0.06, 0.0), (0.29, 0.16, 0.19), TOP),
        Segment(j["Spine2"], "box", (0.0, 0.07, 0.005), (0.32, 0.16, 0.21), TOP),
        Segment(j["Spine3"], "box", (0.0, 0.055, 0.0), (0.37, 0.17, 0.2), TOP),
        Segment(j["Neck"], "box", (0.0, 0.05, 0.0), (0.1, 0.12, 0.1), SKIN),
        Segment(j["Head"], "ellipsoid", (0.0, 0.045, 0.005), (0.165, 0.215, 0.2), SKIN),
        Segment(j["Head"], "ellipsoid", (0.0, 0.085, -0.015), (0.182, 0.17, 0.21), HAIR),
        Segment(j["Head"], "box", (0.0, 0.005, 0.1), (0.024, 0.04, 0.03), SKIN),  # nose
    ]
    for side in "LR":
        sign = 1.0 if side == "L" else -1.0
        segs += [
            Segment(j[f"{side}Eye"], "ellipsoid", (0.0, 0.0, 0.0), (0.03, 0.03, 0.03), EYE_WHITE),
            Segment(j[f"{side}Eye"], "ellipsoid", (0.0, 0.0, 0.0125), (0.015, 0.015, 0.01), PUPIL),
            Segment(j[f"{side}Shoulder"], "ellipsoid", (-0.01 * sign, -0.01, 0.0), (0.12, 0.12, 0.12), TOP),
            Segment(j[f"{side}Shoulder"], "box", (0.0, -0.145, 0.0), (0.095, 0.3, 0.1), TOP),
            Segment(j[f"{side}Elbow"], "box", (0.0, -0.125, 0.0), (0.075, 0.26, 0.08), SKIN),
            Segment(j[f"{side}Wrist"], "ellipsoid", (0.0, -0.085, 0.0), (0.04, 0.17, 0.085), SKIN),
            Segment(j[f"{side}Hip"], "box", (0.0, -0.215, 0.0), (0.15, 0.45, 0.15), TROUSERS),
            Segment(j[f"{side}Knee"], "box", (0.0, -0.2, 0.0), (0.11, 0.42, 0.11), TROUSERS),
            Segment(j[f"{side}Ankle"], "box", (0.0, -0.045, 0.035), (0.1, 0.07, 0.2), HAIR),  # shoe
            Segment(j[f"{side}Toe"], "box", (0.0, 0.0, 0.03), (0.095, 0.04, 0.07), HAIR),  # toe cap
        ]
    return Skeleton(names=names, parents=parents, segments=tuple(segs))


BODY = _body_skeleton()


# -- looks -----------------------------------------------------------------------------------

_SKINS = (
    np.array(
        [[0.85, 0.62, 0.48], [0.70, 0.48, 0.34], [0.48, 0.31, 0.20], [0.30, 0.18, 0.11], [0.92, 0.72, 0.58]]
    )
    ** 2.2
)
_TOPS = (
    np.array(
        [
            [0.80, 0.15, 0.15],
            [0.15, 0.35, 0.75],
            [0.20, 0.55, 0.25],
            [0.90, 0.75, 0.20],
            [0.55, 0.25, 0.60],
            [0.85, 0.85, 0.85],
            [0.20, 0.20, 0.22],
            [0.95, 0.50, 0.15],
            [0.30, 0.65, 0.70],
            [0.60, 0.45, 0.30],
        ]
    )
    ** 2.2
)
_TROUSERS = (
    np.array(
        [
            [0.15, 0.18, 0.30],
            [0.25, 0.25, 0.27],
            [0.40, 0.33, 0.25],
            [0.08, 0.08, 0.09],
            [0.45, 0.45, 0.50],
            [0.30, 0.22, 0.15],
        ]
    )
    ** 2.2
)
_HAIR = (
    np.array(
        [[0.06, 0.05, 0.04], [0.25, 0.15, 0.08], [0.55, 0.40, 0.20], [0.45, 0.45, 0.45], [0.12, 0.08, 0.06]]
    )
    ** 2.2
)


def _hash01(ids: np.ndarray, salt: int) -> np.ndarray:
    """Uniform [0, 1) per id (splitmix64), stable across runs and platforms."""
    with np.errstate(over="ignore"):
        z = np.asarray(ids, dtype=np.uint64) + np.uint64(salt) * np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def agent_looks(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-agent palette ``(N, 4, 3)`` (skin, top, trousers, hair) and body height ``(N,)`` in metres.

    Drawn from the stable agent id, so an agent keeps its clothes and height
    for the whole run and across runs. Heights 1.55–1.92 m.
    """
    ids = np.asarray(ids, dtype=np.int64)
    pick = [(_SKINS, 1), (_TOPS, 2), (_TROUSERS, 3), (_HAIR, 4)]
    palette = np.stack(
        [table[(_hash01(ids, salt) * len(table)).astype(np.int64)] for table, salt in pick], axis=1
    )
    height = 1.55 + 0.37 * _hash01(ids, 5)
    return palette.astype(np.float32), height




# -- without a body ----------------------------------------------------------------------------


def default_dims(ids: np.ndarray) -> np.ndarray:
    """Body dims ``(N, 4)`` (height, sex, build, scale) for agents that have no body: height from the id."""
    _, height = agent_looks(ids)
    dims = np.zeros((len(height), 4))
    dims[:, 0], dims[:, 2], dims[:, 3] = height, 0.5, height / REFERENCE_HEIGHT
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


# -- the mesh ----------------------------------------------------------------------------------


def _unit_box() -> tuple[np.ndarray, np.ndarray]:
    pos, nrm = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = np.zeros(3)
            n[axis] = sign
            u, v = np.zeros(3), np.zeros(3)
            u[(axis + 1) % 3], v[(axis + 2) % 3] = 1.0, 1.0
            if sign < 0:
                u, v = v, u
            c = n * 0.5
            quad = [c - u / 2 - v / 2, c + u / 2 - v / 2, c + u / 2 + v / 2, c - u / 2 + v / 2]
            for k in (0, 1, 2, 0, 2, 3):
                pos.append(quad[k])
                nrm.append(n)
    return np.asarray(pos), np.asarray(nrm)


def unit_sphere(*, rings: int = 8, sectors: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of a sphere of radius 0.5 (positions, normals), counter-clockwise outside."""
    pos = []
    for r in range(rings):
        t0, t1 = math.pi * r / rings, math.pi * (r + 1) / rings
        for s in range(sectors):
            p0, p1 = 2 * math.pi * s / sectors, 2 * math.pi * (s + 1) / sectors

            def pt(t: float, p: float) -> np.ndarray:
                return np.array([math.sin(t) * math.cos(p), math.cos(t), -math.sin(t) * math.sin(p)])

            a, b, c, d = pt(t0, p0), pt(t1, p0), pt(t1, p1), pt(t0, p1)
            if r > 0:
                pos += [a, b, d]
            if r < rings - 1:
                pos += [d, b, c]
    n = np.asarray(pos)
    return n * 0.5, n


def skeleton_mesh(skeleton: Skeleton) -> np.ndarray:
    """Interleaved vertices of all segments: structured array (pos f4×3, normal f4×3, bone i4, slot i4)."""
    box_p, box_n = _unit_box()
    sph_p, sph_n = unit_sphere()
    parts = []
    for seg in skeleton.segments:
        p, nrm = (box_p, box_n) if seg.shape == "box" else (sph_p, sph_n)
        size = np.asarray(seg.size)
        vp = p * size + np.asarray(seg.center)
        vn = nrm / size  # inverse-transpose of a scale
        vn /= np.linalg.norm(vn, axis=1, keepdims=True)
        v = np.zeros(len(vp), dtype=VERTEX_DTYPE)
        v["pos"], v["normal"], v["bone"], v["slot"] = vp, vn, seg.bone, seg.slot
        parts.append(v)
    return np.concatenate(parts)


VERTEX_DTYPE = np.dtype([("pos", "<f4", 3), ("normal", "<f4", 3), ("bone", "<i4"), ("slot", "<i4")])
