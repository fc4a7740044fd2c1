"""Person-shaped figures: a skeleton, body segments per bone, per-agent looks, and a procedural pose.

The renderer draws a crowd from two arrays: bone matrices ``(N, J, 4, 4)``
(bone-local to world, per agent and joint) and a palette ``(N, 4, 3)``
(skin, top, trousers, hair/shoes; linear RGB). A :class:`Skeleton` says
which segments (boxes and ellipsoids shaped like a head, torso, limbs, eyes
with pupils) hang on which bone; the mesh of all segments is drawn instanced,
one draw call for the whole crowd (DESIGN.md "render").

Until the body layer (DESIGN.md "body": 26 joints, footsteps, gaze
controller) provides world transforms, :class:`ProceduralPoser` derives a
16-joint pose from the 2D state (PedVR §3.6: the skeleton follows the
agent's position, heading and speed): a walk cycle whose phase advances
with distance walked, and a head and eyes turned toward each agent's gaze
target (eyes lead within ±35°, the head takes the rest within ±70°). Swapping
in the body layer means a second :class:`Skeleton` with that layer's joint
names and segments, and passing its ``(N, J, 4, 4)`` array instead.

Character frame: ``+X`` forward, ``+Y`` up, ``+Z`` to the character's right
(see :mod:`pedvr.render.math3d`); ``_l`` joints are on its left (``−Z``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pedvr.render.math3d import ground_to_world

# Colour slots of a segment; 0-3 vary per agent (the palette), 4-5 are fixed in the shader.
SKIN, TOP, TROUSERS, HAIR, EYE_WHITE, PUPIL = range(6)
NOMINAL_HEIGHT = 1.76  # m, top of the head of the unscaled procedural skeleton
EYE_HEIGHT_FRACTION = 1.652 / NOMINAL_HEIGHT  # eye height / body height of the procedural skeleton
STEP_LENGTH = 0.7  # m per step at a normal walk: the cycle (two steps) advances 2π per 1.4 m
EYE_YAW_LIMIT = math.radians(35.0)
EYE_PITCH_LIMIT = math.radians(25.0)
HEAD_YAW_LIMIT = math.radians(70.0)
HEAD_PITCH_LIMIT = math.radians(35.0)


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


def _procedural_skeleton() -> Skeleton:
    names = (
        "root",
        "pelvis",
        "spine",
        "chest",
        "neck",
        "head",
        "eye_l",
        "eye_r",
        "upper_arm_l",
        "forearm_l",
        "upper_arm_r",
        "forearm_r",
        "thigh_l",
        "shin_l",
        "thigh_r",
        "shin_r",
    )
    parents = (-1, 0, 1, 2, 3, 4, 5, 5, 3, 8, 3, 10, 1, 12, 1, 14)
    j = {n: i for i, n in enumerate(names)}
    segs = [
        Segment(j["pelvis"], "box", (0.0, 0.0, 0.0), (0.2, 0.2, 0.34), TROUSERS),
        Segment(j["spine"], "box", (0.0, 0.13, 0.0), (0.19, 0.28, 0.33), TOP),
        Segment(j["chest"], "box", (0.0, 0.04, 0.0), (0.22, 0.24, 0.42), TOP),
        Segment(j["neck"], "box", (0.0, 0.04, 0.0), (0.1, 0.12, 0.1), SKIN),
        Segment(j["head"], "ellipsoid", (0.0, 0.072, 0.0), (0.2, 0.245, 0.18), SKIN),
        Segment(j["head"], "ellipsoid", (-0.025, 0.115, 0.0), (0.2, 0.19, 0.19), HAIR),
        Segment(j["head"], "box", (0.1, 0.04, 0.0), (0.035, 0.045, 0.025), SKIN),  # nose
        Segment(j["eye_l"], "ellipsoid", (0.0, 0.0, 0.0), (0.036, 0.036, 0.036), EYE_WHITE),
        Segment(j["eye_l"], "ellipsoid", (0.014, 0.0, 0.0), (0.014, 0.018, 0.018), PUPIL),
        Segment(j["eye_r"], "ellipsoid", (0.0, 0.0, 0.0), (0.036, 0.036, 0.036), EYE_WHITE),
        Segment(j["eye_r"], "ellipsoid", (0.014, 0.0, 0.0), (0.014, 0.018, 0.018), PUPIL),
    ]
    for side in "lr":
        segs += [
            Segment(j[f"upper_arm_{side}"], "box", (0.0, -0.14, 0.0), (0.09, 0.3, 0.09), TOP),
            Segment(j[f"forearm_{side}"], "box", (0.0, -0.13, 0.0), (0.075, 0.27, 0.075), SKIN),
            Segment(j[f"forearm_{side}"], "ellipsoid", (0.0, -0.3, 0.0), (0.08, 0.1, 0.06), SKIN),
            Segment(j[f"thigh_{side}"], "box", (0.0, -0.22, 0.0), (0.13, 0.46, 0.13), TROUSERS),
            Segment(j[f"shin_{side}"], "box", (0.0, -0.22, 0.0), (0.1, 0.44, 0.1), TROUSERS),
            Segment(j[f"shin_{side}"], "box", (0.05, -0.445, 0.0), (0.25, 0.07, 0.1), HAIR),
        ]
    return Skeleton(names=names, parents=parents, segments=tuple(segs))


PROCEDURAL = _procedural_skeleton()

# Rest offsets of each procedural joint from its parent (parent frame, unscaled metres).
_REST = {
    "root": (0.0, 0.0, 0.0),
    "pelvis": (0.0, 0.95, 0.0),
    "spine": (0.0, 0.07, 0.0),
    "chest": (0.0, 0.3, 0.0),
    "neck": (0.0, 0.18, 0.0),
    "head": (0.0, 0.08, 0.0),
    "eye_l": (0.085, 0.072, -0.033),
    "eye_r": (0.085, 0.072, 0.033),
    "upper_arm_l": (0.0, 0.14, -0.2),
    "forearm_l": (0.0, -0.29, 0.0),
    "upper_arm_r": (0.0, 0.14, 0.2),
    "forearm_r": (0.0, -0.29, 0.0),
    "thigh_l": (0.0, -0.02, -0.09),
    "shin_l": (0.0, -0.45, 0.0),
    "thigh_r": (0.0, -0.02, 0.09),
    "shin_r": (0.0, -0.45, 0.0),
}


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


# -- the procedural pose -----------------------------------------------------------------------


def _rot(axis: str, a: np.ndarray) -> np.ndarray:
    """(N, 4, 4) rotations about a local axis by angles ``a`` (N,)."""
    n = a.shape[0]
    m = np.zeros((n, 4, 4))
    m[:, 3, 3] = 1.0
    c, s = np.cos(a), np.sin(a)
    i, k = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m[:, "xyz".index(axis), "xyz".index(axis)] = 1.0
    m[:, i, i], m[:, i, k], m[:, k, i], m[:, k, k] = c, -s, s, c
    return m


def _translate(n: int, offset: tuple[float, float, float]) -> np.ndarray:
    m = np.tile(np.eye(4), (n, 1, 1))
    m[:, :3, 3] = offset
    return m


def _aim_angles(local_dir: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Yaw (about +Y) and pitch (about +Z) turning local +X onto ``local_dir`` (N, 3)."""
    dx, dy, dz = local_dir[:, 0], local_dir[:, 1], local_dir[:, 2]
    return np.arctan2(-dz, dx), np.arctan2(dy, np.hypot(dx, dz))


class ProceduralPoser:
    """Bone matrices from the 2D state: walk cycle plus head and eyes toward a gaze target.

    Keeps a walk phase per agent id (render-side state only; it reads the
    simulation, never writes it). Call :meth:`pose` once per rendered frame
    with the time elapsed since the last call.
    """

    skeleton = PROCEDURAL

    def __init__(self) -> None:
        self._phase: dict[int, float] = {}

    def pose(
        self,
        *,
        ids: np.ndarray,
        pos: np.ndarray,
        heading: np.ndarray,
        vel: np.ndarray,
        height: np.ndarray,
        gaze_target: np.ndarray | None = None,
        dt: float = 0.0,
    ) -> np.ndarray:
        """World transforms ``(N, J, 4, 4)`` float32 of every agent's joints.

        ``gaze_target`` is ``(N, 3)`` world points (NaN rows: look ahead) the
        head and eyes turn toward. ``dt`` advances the walk phase.
        """
        ids = np.asarray(ids, dtype=np.int64)
        n = ids.shape[0]
        speed = np.linalg.norm(np.asarray(vel, dtype=np.float64).reshape(n, 2), axis=1)
        phase = np.fromiter((self._phase.get(int(i), 0.37 * float(i)) for i in ids), np.float64, n)
        phase = phase + 2.0 * math.pi * speed * dt / (2.0 * STEP_LENGTH)
        self._phase = {int(i): float(p % (2 * math.pi)) for i, p in zip(ids, phase, strict=True)}
        return procedural_pose(
            pos=pos, heading=heading, speed=speed, height=height, phase=phase, gaze_target=gaze_target
        )


def procedural_pose(
    *,
    pos: np.ndarray,
    heading: np.ndarray,
    speed: np.ndarray,
    height: np.ndarray,
    phase: np.ndarray,
    gaze_target: np.ndarray | None = None,
) -> np.ndarray:
    """Stateless core of :class:`ProceduralPoser`: world bone matrices ``(N, J, 4, 4)`` float32."""
    sk = PROCEDURAL
    n = int(np.asarray(heading).shape[0])
    pos = np.asarray(pos, dtype=np.float64).reshape(n, 2)
    heading = np.asarray(heading, dtype=np.float64).reshape(n)
    scale = np.asarray(height, dtype=np.float64).reshape(n) / NOMINAL_HEIGHT
    amp = 0.45 * np.clip(np.asarray(speed, dtype=np.float64) / 1.3, 0.0, 1.0)
    s = np.sin(phase)

    root = _rot("y", -heading)  # heading θ -> yaw −θ (math3d)
    root[:, :3, :3] *= scale[:, None, None]
    root[:, :3, 3] = ground_to_world(pos)

    local = {name: _translate(n, off) for name, off in _REST.items()}
    local["pelvis"][:, 1, 3] -= 0.025 * amp * (1.0 - np.abs(np.cos(phase)))
    local["thigh_l"] = local["thigh_l"] @ _rot("z", amp * s)
    local["thigh_r"] = local["thigh_r"] @ _rot("z", -amp * s)
    local["shin_l"] = local["shin_l"] @ _rot("z", -1.2 * amp * np.maximum(0.0, -np.cos(phase)))
    local["shin_r"] = local["shin_r"] @ _rot("z", -1.2 * amp * np.maximum(0.0, np.cos(phase)))
    local["upper_arm_l"] = local["upper_arm_l"] @ _rot("z", -0.7 * amp * s) @ _rot("x", np.full(n, -0.06))
    local["upper_arm_r"] = local["upper_arm_r"] @ _rot("z", 0.7 * amp * s) @ _rot("x", np.full(n, 0.06))
    local["forearm_l"] = local["forearm_l"] @ _rot("z", np.full(n, 0.2) + 0.3 * amp)
    local["forearm_r"] = local["forearm_r"] @ _rot("z", np.full(n, 0.2) + 0.3 * amp)

    world = np.empty((n, sk.joints, 4, 4))
    world[:, 0] = root
    head_j = sk.index("head")
    for j in range(1, head_j):
        world[:, j] = world[:, sk.parents[j]] @ local[sk.names[j]]

    # Gaze: the head turns toward the target within its limits, the eyes take the rest (eyes lead).
    head_yaw = np.zeros(n)
    head_pitch = np.zeros(n)
    eye_yaw = np.zeros(n)
    eye_pitch = np.zeros(n)
    if gaze_target is not None:
        g = np.asarray(gaze_target, dtype=np.float64).reshape(n, 3)
        has = np.all(np.isfinite(g), axis=1)
        if has.any():
            neck = world[:, sk.index("neck")]
            head_frame = neck @ local["head"]
            mid_eye = head_frame @ np.array([0.085, 0.072, 0.0, 1.0])
            d_world = g - mid_eye[:, :3]
            # Into the neck's frame (rotation only; the scale is uniform and drops out of the angles).
            d_local = np.einsum("nji,nj->ni", neck[:, :3, :3], np.where(has[:, None], d_world, 1.0))
            yaw, pitch = _aim_angles(d_local)
            head_yaw = np.where(has, np.clip(yaw, -HEAD_YAW_LIMIT, HEAD_YAW_LIMIT) * 0.7, 0.0)
            head_pitch = np.where(has, np.clip(pitch, -HEAD_PITCH_LIMIT, HEAD_PITCH_LIMIT) * 0.6, 0.0)
            eye_yaw = np.where(has, np.clip(yaw - head_yaw, -EYE_YAW_LIMIT, EYE_YAW_LIMIT), 0.0)
            eye_pitch = np.where(has, np.clip(pitch - head_pitch, -EYE_PITCH_LIMIT, EYE_PITCH_LIMIT), 0.0)
    local["head"] = local["head"] @ _rot("y", head_yaw) @ _rot("z", head_pitch)
    eye_rot = _rot("y", eye_yaw) @ _rot("z", eye_pitch)
    local["eye_l"] = local["eye_l"] @ eye_rot
    local["eye_r"] = local["eye_r"] @ eye_rot
    for j in range(head_j, sk.joints):
        world[:, j] = world[:, sk.parents[j]] @ local[sk.names[j]]
    return world.astype(np.float32)


def eye_height_of(height: float | np.ndarray) -> float | np.ndarray:
    """Eye height of a procedural figure of body ``height`` (the first-person camera's height)."""
    return height * EYE_HEIGHT_FRACTION


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
