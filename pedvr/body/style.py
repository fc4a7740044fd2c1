"""Emotional upper-body walking styles (Ashida et al. 2001, §4.2.2).

Each of the 11 upper-body DOFs follows ``R_j = A_j sin(a_j t + b_j)^{p_j} + B_j``
on the gait phase ``t`` (radians, 0 at the left heel strike, 2π per gait
cycle); the right side of a mirrored DOF uses ``t + π``. ``x^p`` of a negative
base is ``sign(x)|x|^p``. A style is the 11 × 5 table ``(A, a, b, p, B)``;
an agent's style is the emotion-weighted barycentre of the six sets below.

Sign conventions (anatomical, degrees in the tables, radians at run time):
shoulder flexion + forward, abduction + outward, elbow flexion +, clavicle
elevation + up and protraction + forward, spine flexion + forward, lateral
bend + toward the left, twist + turns the left shoulder back. The lower
spine also counter-rotates the pelvis (done in :mod:`pedvr.body.pose`), so
the pelvis's gait rotation does not reach the thorax (Ashida's i-th joint).

The amplitudes ``A`` are scaled by the gait amplitude (speed / 1.3 m/s,
smoothed), so a standing person keeps the posture ``B`` but stops swinging.

Emotion also sets walking speed (:data:`SPEED_FACTOR`): sad and tired walk
slower, angry and happy faster.
"""

from __future__ import annotations

import numpy as np

EMOTIONS = ("neutral", "happy", "sad", "angry", "worried", "tired")
N_EMOTIONS = len(EMOTIONS)
DOFS = ("elbow_flex", "shoulder_flex", "shoulder_abd", "clavicle_elev", "clavicle_prot",
        "upper_flex", "upper_bend", "upper_twist", "lower_flex", "lower_bend", "lower_twist")
N_DOFS = len(DOFS)
MIRRORED = 5  # DOFs 0..4 exist on both sides, the right one phase-shifted by π
PA, Pa, Pb, Pp, PB = 0, 1, 2, 3, 4

SPEED_FACTOR = np.array([1.0, 1.08, 0.8, 1.1, 0.95, 0.85])
"""Preferred-speed factor per emotion (sad: slower)."""

_H = -np.pi / 2  # arm swing phase: the left arm is back at the left heel strike


def _set(**dofs: tuple[float, float, float, float, float]) -> np.ndarray:
    """A style table from ``dof=(A°, a, b rad, p, B°)``; unspecified DOFs are still."""
    t = np.zeros((N_DOFS, 5))
    t[:, Pa] = 1.0
    t[:, Pp] = 1.0
    for name, (amp, a, b, p, base) in dofs.items():
        t[DOFS.index(name)] = (np.radians(amp), a, b, p, np.radians(base))
    return t


STYLES = np.stack([
    _set(shoulder_flex=(16, 1, _H, 1, 2), elbow_flex=(8, 1, _H, 1, 15), shoulder_abd=(0, 1, 0, 1, 6),
         clavicle_elev=(1, 2, 0, 1, 0), clavicle_prot=(3, 1, _H, 1, 0), upper_flex=(1, 2, 0, 1, 2),

         upper_twist=(3, 1, np.pi / 2, 1, 0),
         lower_flex=(1, 2, 0, 1, 1), lower_twist=(2, 1, np.pi / 2, 1, 0)),
    _set(shoulder_flex=(24, 1, _H, 1, 4), elbow_flex=(12, 1, _H, 1, 22), shoulder_abd=(0, 1, 0, 1, 9),
         clavicle_elev=(2, 2, 0, 1, -2), clavicle_prot=(4, 1, _H, 1, -3), upper_flex=(1.5, 2, 0, 1, -3),

         upper_twist=(5, 1, np.pi / 2, 1, 0),
         lower_flex=(1, 2, 0, 1, -1), lower_twist=(3, 1, np.pi / 2, 1, 0)),
    _set(shoulder_flex=(6, 1, _H, 1.5, -2), elbow_flex=(3, 1, _H, 1, 8), shoulder_abd=(0, 1, 0, 1, 3),
         clavicle_elev=(0.5, 2, 0, 1, -4), clavicle_prot=(1, 1, _H, 1, 8), upper_flex=(1, 2, 0, 1, 14),

         upper_twist=(1, 1, np.pi / 2, 1, 0),
         lower_flex=(0.5, 2, 0, 1, 5), lower_twist=(1, 1, np.pi / 2, 1, 0)),
    _set(shoulder_flex=(22, 1, _H, 0.7, 0), elbow_flex=(10, 1, _H, 1, 35), shoulder_abd=(0, 1, 0, 1, 12),
         clavicle_elev=(1.5, 2, 0, 1, 5), clavicle_prot=(4, 1, _H, 1, 4), upper_flex=(1.5, 2, 0, 1, 6),

         upper_twist=(6, 1, np.pi / 2, 1, 0),
         lower_flex=(1, 2, 0, 1, 3), lower_twist=(3, 1, np.pi / 2, 1, 0)),
    _set(shoulder_flex=(9, 1, _H, 1, 4), elbow_flex=(5, 1, _H, 1, 30), shoulder_abd=(0, 1, 0, 1, 4),
         clavicle_elev=(1, 2, 0, 1, 6), clavicle_prot=(2, 1, _H, 1, 6), upper_flex=(1, 2, 0, 1, 5),

         upper_twist=(2, 1, np.pi / 2, 1, 0),
         lower_flex=(1, 2, 0, 1, 2), lower_twist=(1.5, 1, np.pi / 2, 1, 0)),
    _set(shoulder_flex=(8, 1, _H, 1.3, -1), elbow_flex=(4, 1, _H, 1, 10), shoulder_abd=(0, 1, 0, 1, 3),
         clavicle_elev=(0.5, 2, 0, 1, -3), clavicle_prot=(1, 1, _H, 1, 5), upper_flex=(1, 2, 0, 1, 10),

         upper_twist=(2, 1, np.pi / 2, 1, 0),
         lower_flex=(1, 2, 0, 1, 4), lower_twist=(1.5, 1, np.pi / 2, 1, 0)),
])
"""``(6, 11, 5)``: the style sets, in :data:`EMOTIONS` order."""


def blend_style(emotion: np.ndarray) -> np.ndarray:
    """Per-agent style ``(N, 11, 5)`` from emotion weights ``(N, 6)`` (normalized here)."""
    w = np.asarray(emotion, np.float64)
    w = w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)
    return np.ascontiguousarray(np.einsum("ne,edk->ndk", w, STYLES))


def speed_factor(emotion: np.ndarray) -> np.ndarray:
    w = np.asarray(emotion, np.float64)
    w = w / np.maximum(w.sum(axis=1, keepdims=True), 1e-12)
    return w @ SPEED_FACTOR


def draw_emotions(rng: np.random.Generator, n: int) -> np.ndarray:
    """Emotion weights ``(n, 6)``: 60 % purely neutral; otherwise one emotion drawn
    uniformly among the five others with intensity u ~ U(0.3, 1), the rest neutral.

    Draw order: ``neutral? (n)``, ``emotion index (n)``, ``intensity (n)``.
    """
    neutral = rng.random(n) < 0.6
    which = rng.integers(1, N_EMOTIONS, size=n)
    u = rng.uniform(0.3, 1.0, size=n)
    out = np.zeros((n, N_EMOTIONS))
    out[:, 0] = np.where(neutral, 1.0, 1.0 - u)
    out[np.arange(n), which] += np.where(neutral, 0.0, u)
    return out


def one_hot(name: str, n: int = 1) -> np.ndarray:
    out = np.zeros((n, N_EMOTIONS))
    out[:, EMOTIONS.index(name)] = 1.0
    return out
