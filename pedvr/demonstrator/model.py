"""The placement model of PLACE (Huang & Kallmann §3, Fig. 5, Appendix A) and its local frame.

The model lives in a 2D frame with its origin at the target ``p_t`` and its Z
axis orthogonal to the edge of the supporting table closest to the target.
Angles are degrees:

``α``  the observer's position, measured from Z;
``β``  the demonstrator's position, measured from −Z;
``θ``  the demonstrator's body orientation (its facing at the action), from Z;
``φ``  the maximum head rotation toward the observer, from Z.

Appendix A fits β (cubic), θ and φ (quadratic) as functions of α;
:func:`placement_model` evaluates the printed polynomials exactly.

Choices where the paper is silent (§3, Fig. 5 give no handedness):

* **Sign of the angles.** Fig. 5's frame is the XZ plane of a Y-up scene, so
  the angles are read as rotations about +Y by the right-hand rule: from Z
  toward X, which is the *left* of a body that faces Z (pedvr's body frame:
  +Z forward, +X left, :mod:`pedvr.body`). The fits' asymmetry agrees with a
  right-handed pointer: an observer on the left (α = +90°) turns the body by
  θ = 46°, one on the right (α = −90°) only by −13° (the pointing right arm
  stays in front). In pedvr's ground coordinates (``(x, y)`` = 3D ``(x, z)``,
  headings counter-clockwise from +x) a positive local angle is therefore a
  *clockwise* turn: global heading = ``zeta − radians(angle)``.
* **Direction of Z.** Z points from the target out through the closest edge
  of the obstacle the target stands on (its outward normal), so an observer in
  front of that edge has α ≈ 0 and the model puts the demonstrator across the
  target, facing the observer (β ≈ −6° from −Z, θ ≈ 11°): the paper's "directly
  face the observer". A target not on an obstacle uses the exhibit's facing.
"""

from __future__ import annotations

import math

import numpy as np

from pedvr.errors import PedvrError

# Appendix A coefficients (95 % confidence bounds omitted).
BETA_P = (2.392e-6, 0.0003056, 0.1145, -6.062)  # cubic
THETA_P = (0.0006228, 0.3267, 11.29)  # quadratic
PHI_P = (0.0006673, 0.6736, 2.073)  # quadratic


class PlacementError(PedvrError, ValueError):
    """A placement query with an invalid argument (an angle outside [−180, 180], a non-finite point)."""


def placement_model(alpha_deg: float) -> tuple[float, float, float]:
    """``(β, θ, φ)`` in degrees for the observer angle ``α`` (degrees, in [−180, 180]).

    The Appendix A polynomials, evaluated exactly as printed::

        β = 2.392e-6·α³ + 0.0003056·α² + 0.1145·α − 6.062
        θ = 0.0006228·α² + 0.3267·α + 11.29
        φ = 0.0006673·α² + 0.6736·α + 2.073

    Raises :class:`PlacementError` for an α outside [−180, 180] or not finite.
    """
    a = float(alpha_deg)
    if not (math.isfinite(a) and -180.0 <= a <= 180.0):
        raise PlacementError(f"alpha_deg = {alpha_deg!r}: must be a finite angle in [-180, 180] degrees")
    p1, p2, p3, p4 = BETA_P
    q1, q2, q3 = THETA_P
    r1, r2, r3 = PHI_P
    beta = p1 * a**3 + p2 * a**2 + p3 * a + p4
    theta = q1 * a**2 + q2 * a + q3
    phi = r1 * a**2 + r2 * a + r3
    return beta, theta, phi


def placement_model_array(alpha_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`placement_model` over an array of α (degrees, assumed in [−180, 180]); the planner's form."""
    a = np.asarray(alpha_deg, np.float64)
    p1, p2, p3, p4 = BETA_P
    q1, q2, q3 = THETA_P
    r1, r2, r3 = PHI_P
    a2 = a * a
    return p1 * a2 * a + p2 * a2 + p3 * a + p4, q1 * a2 + q2 * a + q3, r1 * a2 + r2 * a + r3


def wrap_deg(a: np.ndarray | float) -> np.ndarray | float:
    """Angles wrapped to [−180, 180)."""
    if isinstance(a, np.ndarray):
        return (a + 180.0) % 360.0 - 180.0
    return (a + 180.0) % 360.0 - 180.0


def local_angle(zeta: float | np.ndarray, direction: float | np.ndarray) -> np.ndarray | float:
    """The local angle (degrees, from Z, module convention) of a global direction (rad)."""
    return wrap_deg(np.degrees(np.asarray(zeta) - np.asarray(direction)))


def global_heading(zeta: float | np.ndarray, angle_deg: float | np.ndarray) -> np.ndarray:
    """The global heading (rad, pedvr's ground frame) of a local angle measured from Z."""
    return np.asarray(zeta) - np.radians(angle_deg)


def observer_angle(target: tuple[float, float], observer: tuple[float, float], zeta: float) -> float:
    """α: the observer's direction from the target, in the local frame whose Z has heading ``zeta``."""
    d = math.atan2(observer[1] - target[1], observer[0] - target[0])
    return float(local_angle(zeta, d))


def demonstrator_pose(target: tuple[float, float], zeta: float, alpha_deg: float,
                      distance: float) -> tuple[tuple[float, float], float, float, float]:
    """The model's placement for one frame orientation: ``(p_d, heading, theta_deg, phi_deg)``.

    ``p_d`` lies ``distance`` m from the target along −Z turned by β; ``heading``
    (rad, global) is Z turned by θ.
    """
    beta, theta, phi = placement_model(alpha_deg)
    pos_dir = zeta + math.pi - math.radians(beta)
    p = (target[0] + distance * math.cos(pos_dir), target[1] + distance * math.sin(pos_dir))
    return p, zeta - math.radians(theta), theta, phi
