"""The 26-joint humanoid: names, parents, rest offsets, end sites, per-agent scaling.

Local frame of the skeleton (glTF-like): **+Y up, +Z forward (the way the
character faces), +X the character's anatomical left**. Every joint's rest
rotation is the identity, so rest offsets are expressed in the body frame:
the bind pose is a person standing with arms hanging at the sides.

Proportions are those of a 1.75 m adult (hip joints 0.93 m, eyes 1.64 m,
shoulder joints 0.45 m apart, head top 1.75 m, ankles 0.08 m) and scale per
agent: lengths by ``height / 1.75``, then shoulder and hip widths by sex and
build (:func:`dims_offsets`).

Nodes ``0 .. J-1`` are the 26 joints (``JOINTS``); nodes ``J .. K-1`` are
the end sites (``END_SITES``: head top, heels, toe tips, hand tips), which
carry no rotation of their own. Parents always precede children, so one
forward pass in node order is a valid forward kinematics order.
"""

from __future__ import annotations

import numpy as np
from numba import njit

JOINTS: tuple[str, ...] = (
    "Pelvis",
    "LHip", "LKnee", "LAnkle", "LToe",
    "RHip", "RKnee", "RAnkle", "RToe",
    "Spine1", "Spine2", "Spine3", "Neck", "Head", "LEye", "REye",
    "LCollar", "LShoulder", "LElbow", "LWrist", "LHand",
    "RCollar", "RShoulder", "RElbow", "RWrist", "RHand",
)
END_SITES: tuple[str, ...] = ("HeadTop", "LHeel", "RHeel", "LToeTip", "RToeTip", "LHandTip", "RHandTip")
NODES: tuple[str, ...] = JOINTS + END_SITES
J = len(JOINTS)  # 26
K = len(NODES)  # 33

IDX = {name: k for k, name in enumerate(NODES)}
PELVIS, L_HIP, L_KNEE, L_ANKLE, L_TOE = 0, 1, 2, 3, 4
R_HIP, R_KNEE, R_ANKLE, R_TOE = 5, 6, 7, 8
SPINE1, SPINE2, SPINE3, NECK, HEAD, L_EYE, R_EYE = 9, 10, 11, 12, 13, 14, 15
L_COLLAR, L_SHOULDER, L_ELBOW, L_WRIST, L_HAND = 16, 17, 18, 19, 20
R_COLLAR, R_SHOULDER, R_ELBOW, R_WRIST, R_HAND = 21, 22, 23, 24, 25
HEAD_TOP, L_HEEL, R_HEEL, L_TOE_TIP, R_TOE_TIP, L_HAND_TIP, R_HAND_TIP = 26, 27, 28, 29, 30, 31, 32

_PARENT_NAMES = {
    "Pelvis": None,
    "LHip": "Pelvis", "LKnee": "LHip", "LAnkle": "LKnee", "LToe": "LAnkle",
    "RHip": "Pelvis", "RKnee": "RHip", "RAnkle": "RKnee", "RToe": "RAnkle",
    "Spine1": "Pelvis", "Spine2": "Spine1", "Spine3": "Spine2", "Neck": "Spine3", "Head": "Neck",
    "LEye": "Head", "REye": "Head",
    "LCollar": "Spine3", "LShoulder": "LCollar", "LElbow": "LShoulder", "LWrist": "LElbow",
    "LHand": "LWrist",
    "RCollar": "Spine3", "RShoulder": "RCollar", "RElbow": "RShoulder", "RWrist": "RElbow",
    "RHand": "RWrist",
    "HeadTop": "Head", "LHeel": "LAnkle", "RHeel": "RAnkle", "LToeTip": "LToe", "RToeTip": "RToe",
    "LHandTip": "LHand", "RHandTip": "RHand",
}
PARENTS = np.array([IDX.get(_PARENT_NAMES[n] or "", -1) for n in NODES], np.int64)
"""``(K,) int64``: parent node of each node, -1 for the pelvis (its parent is the root)."""

# Rest offsets of the 1.75 m reference adult, metres, in the parent's (= body) frame.
# The pelvis offset is its height above the ground root.
_REST = {
    "Pelvis": (0.0, 0.98, 0.0),
    "LHip": (0.09, -0.05, 0.0), "RHip": (-0.09, -0.05, 0.0),
    "LKnee": (0.0, -0.43, 0.0), "RKnee": (0.0, -0.43, 0.0),
    "LAnkle": (0.0, -0.42, 0.0), "RAnkle": (0.0, -0.42, 0.0),
    "LToe": (0.0, -0.06, 0.135), "RToe": (0.0, -0.06, 0.135),
    "Spine1": (0.0, 0.10, -0.01), "Spine2": (0.0, 0.12, 0.0), "Spine3": (0.0, 0.14, 0.0),
    "Neck": (0.0, 0.16, 0.0), "Head": (0.0, 0.10, 0.01),
    "LEye": (0.032, 0.04, 0.09), "REye": (-0.032, 0.04, 0.09),
    "LCollar": (0.03, 0.11, 0.0), "RCollar": (-0.03, 0.11, 0.0),
    "LShoulder": (0.195, -0.02, -0.01), "RShoulder": (-0.195, -0.02, -0.01),
    "LElbow": (0.0, -0.29, 0.0), "RElbow": (0.0, -0.29, 0.0),
    "LWrist": (0.0, -0.25, 0.0), "RWrist": (0.0, -0.25, 0.0),
    "LHand": (0.0, -0.08, 0.0), "RHand": (0.0, -0.08, 0.0),
    "HeadTop": (0.0, 0.15, 0.0),
    "LHeel": (0.0, -0.08, -0.055), "RHeel": (0.0, -0.08, -0.055),
    "LToeTip": (0.0, -0.02, 0.06), "RToeTip": (0.0, -0.02, 0.06),
    "LHandTip": (0.0, -0.10, 0.0), "RHandTip": (0.0, -0.10, 0.0),
}
REST_OFFSETS = np.array([_REST[n] for n in NODES], np.float64)
"""``(K, 3) float64``: rest offsets of the 1.75 m reference adult."""

REFERENCE_HEIGHT = 1.75
HEIGHT_RANGE = (1.55, 1.95)

# Columns of the per-agent dims array.
DIM_HEIGHT, DIM_SEX, DIM_BUILD, DIM_SCALE = 0, 1, 2, 3
N_DIMS = 4
SEX_MALE, SEX_FEMALE = 0.0, 1.0

_SHOULDER_NODES = (IDX["LShoulder"], IDX["RShoulder"])
_HIP_NODES = (IDX["LHip"], IDX["RHip"])


def depth_of(node: int) -> int:
    """Joints between ``node`` and the pelvis (pelvis: 0)."""
    d = 0
    while PARENTS[node] >= 0:
        node = int(PARENTS[node])
        d += 1
    return d


def draw_dims(rng: np.random.Generator, n: int, *, sex: float | None = None) -> np.ndarray:
    """Draw ``(n, N_DIMS)`` body dimensions: height, sex, build, scale.

    Sex is female with probability 0.5 (or ``sex``, ``SEX_MALE`` / ``SEX_FEMALE``, when a
    scene profile sets it: the draw is made all the same, so the stream stays aligned);
    heights are normal (men 1.76 ± 0.07 m, women 1.63 ± 0.065 m) clipped to
    ``HEIGHT_RANGE``; build is uniform in [0, 1] (0 slender, 1 heavy). Draw order
    (documented so runs reproduce): ``sex (n), height z (n), build (n)``.
    """
    drawn = (rng.random(n) < 0.5).astype(np.float64)
    sexes = drawn if sex is None else np.full(n, float(sex))
    z = rng.standard_normal(n)
    height = np.where(sexes == SEX_FEMALE, 1.63 + 0.065 * z, 1.76 + 0.07 * z)
    height = np.clip(height, *HEIGHT_RANGE)
    build = rng.random(n)
    out = np.empty((n, N_DIMS))
    out[:, DIM_HEIGHT] = height
    out[:, DIM_SEX] = sexes
    out[:, DIM_BUILD] = build
    out[:, DIM_SCALE] = height / REFERENCE_HEIGHT
    return out


def dims_offsets(dims: np.ndarray) -> np.ndarray:
    """Per-agent rest offsets ``(N, K, 3) float64`` from dims ``(N, N_DIMS)``.

    Every length scales by ``height / 1.75``; then the shoulder width scales
    by 0.92 for women and the hip width by 1.08, and both by ``0.95 + 0.1 * build``.
    """
    scale = dims[:, DIM_SCALE]
    off = REST_OFFSETS[None, :, :] * scale[:, None, None]
    female = dims[:, DIM_SEX] == SEX_FEMALE
    width = 0.95 + 0.1 * dims[:, DIM_BUILD]
    sh = width * np.where(female, 0.92, 1.0)
    hp = width * np.where(female, 1.08, 1.0)
    for k in _SHOULDER_NODES:
        off[:, k, 0] *= sh
    for k in _HIP_NODES:
        off[:, k, 0] *= hp
    return np.ascontiguousarray(off)


_L_SHOULDER, _R_SHOULDER = _SHOULDER_NODES
_L_HIP, _R_HIP = _HIP_NODES


@njit(cache=True, inline="always")
def offsets_row(scale, sex, build, out):  # type: ignore[no-untyped-def]
    """One body's rest offsets ``out (K, 3)`` from its dims, with :func:`dims_offsets`' arithmetic in
    its order, so the same bytes: the pose graph makes them in scratch instead of reading them."""
    for k in range(REST_OFFSETS.shape[0]):
        for c in range(3):
            out[k, c] = REST_OFFSETS[k, c] * scale
    width = 0.95 + 0.1 * build
    female = sex == SEX_FEMALE
    sh = width * (0.92 if female else 1.0)
    hp = width * (1.08 if female else 1.0)
    out[_L_SHOULDER, 0] *= sh
    out[_R_SHOULDER, 0] *= sh
    out[_L_HIP, 0] *= hp
    out[_R_HIP, 0] *= hp


def user_dims(n: int = 1) -> np.ndarray:
    """Dims of the reference adult (the user's body when nothing else is known)."""
    out = np.zeros((n, N_DIMS))
    out[:, DIM_HEIGHT] = REFERENCE_HEIGHT
    out[:, DIM_BUILD] = 0.5
    out[:, DIM_SCALE] = 1.0
    return out
