"""Cameras, views and projections: pure numpy, no GL (PedVR §3.6: the first-person view).

Conventions, stated once:

* **World axes.** The simulation's ground plane is 2D ``(x, y)``; in 3D (Y up,
  right-handed, metres, as OpenGL and OpenXR) a ground point ``(x, y)`` sits at
  ``(x, 0, y)`` (:func:`ground_to_world`). Because 2D ``+y`` becomes 3D ``+z``,
  a 2D heading ``θ`` (counter-clockwise from ``+x`` seen in the 2D plots) is the
  3D direction ``(cos θ, 0, sin θ)``, which is a rotation of ``+x`` about ``+Y``
  by **−θ** (right-hand rule): :func:`heading_to_yaw` returns ``−θ``.
  **Sharp edge: chirality.** The map ``(x, y) -> (x, 0, y)`` is a reflection
  (2D counter-clockwise is clockwise seen from above in 3D), so the 3D world
  is the mirror image of the 2D plot: a person facing 2D ``+x`` has 2D
  ``+y`` on their *right*; increasing the 2D heading turns a person to their
  right. Distances, positions and collisions are unaffected; anything
  sided ("keep right") must be stated in 3D terms. The overhead debug view
  is a true view from above (2D ``+y`` points *down* the screen), so it
  agrees with what the first-person user sees.
* **Matrices** are ``(4, 4)`` float64 arrays in the math convention
  (``M @ column_vector``); shaders receive them transposed into GL's
  column-major order by the renderer.
* **Cameras** look along their local ``−Z`` with ``+Y`` up (OpenGL and OpenXR
  views). A character's local frame is ``+X`` forward, ``+Y`` up, ``+Z`` to its
  right (right-handed: forward × up = right), so its root rotation is
  :func:`rot_y` of :func:`heading_to_yaw`.
* **Projections** are OpenGL clip space (``z`` in ``[−w, w]``), built from the
  four half-angle tangents of an OpenXR ``XrFovf`` (off-axis, one per eye) or
  from a symmetric vertical field of view on the desktop; they equal
  pyopenxr's ``xr.utils.Matrix4x4f.create_projection_fov(GraphicsAPI.OPENGL,
  ...)`` (tested). Near 0.05 m and far 200 m by default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

NEAR = 0.05  # m
FAR = 200.0  # m
IPD = 0.063  # m, interpupillary distance used on the desktop (issue 4)
EYE_HEIGHT = 1.65  # m, standing eye height of an adult (desktop and headless cameras)


def ground_to_world(p: np.ndarray, height: float | np.ndarray = 0.0) -> np.ndarray:
    """2D ground points ``(..., 2)`` to 3D points ``(..., 3)`` at ``height`` (``(x, y) -> (x, h, y)``)."""
    p = np.asarray(p, dtype=np.float64)
    h = np.broadcast_to(np.asarray(height, dtype=np.float64), p.shape[:-1])
    return np.stack([p[..., 0], h, p[..., 1]], axis=-1)


def world_to_ground(p: np.ndarray) -> np.ndarray:
    """3D points ``(..., 3)`` to their floor projection ``(..., 2)`` (``(x, y, z) -> (x, z)``)."""
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], p[..., 2]], axis=-1)


def heading_to_yaw(heading: float | np.ndarray) -> float | np.ndarray:
    """3D yaw about ``+Y`` (right-hand rule) of a 2D heading: ``−θ`` (see the module docstring)."""
    return -np.asarray(heading) if isinstance(heading, np.ndarray) else -heading


def heading_of_direction(d: np.ndarray) -> float:
    """2D heading of a 3D direction, from its floor projection (``atan2(z, x)``)."""
    return math.atan2(float(d[2]), float(d[0]))


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=np.float64)


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=np.float64)


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=np.float64)


def quat_to_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Rotation matrix of a unit quaternion ``(x, y, z, w)`` (OpenXR's ``XrQuaternionf`` order)."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        raise ValueError("quaternion of zero length")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ],
        dtype=np.float64,
    )


def matrix_to_quat(r: np.ndarray) -> tuple[float, float, float, float]:
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix (Shepperd's method)."""
    m = np.asarray(r, dtype=np.float64)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return ((m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s, 0.25 * s)
    if m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2]) * 2
        return (0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s, (m[2, 1] - m[1, 2]) / s)
    if m[1, 1] > m[2, 2]:
        s = math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2]) * 2
        return ((m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s, (m[0, 2] - m[2, 0]) / s)
    s = math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1]) * 2
    return ((m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s, (m[1, 0] - m[0, 1]) / s)


def rigid(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """The 4×4 transform ``[R t; 0 1]``."""
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return m


def view_from_pose(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """World-to-eye matrix of an eye at ``position`` oriented by ``rotation`` (the pose's inverse)."""
    r = np.asarray(rotation, dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = r.T
    m[:3, 3] = -r.T @ np.asarray(position, dtype=np.float64)
    return m


def first_person_rotation(heading: float, pitch: float = 0.0) -> np.ndarray:
    """Orientation of an eye facing 2D ``heading`` and pitched up by ``pitch`` (rad).

    The camera looks along its ``−Z``; yawing by ``−θ − π/2`` turns ``−Z`` onto
    ``(cos θ, 0, sin θ)``; the pitch is about the camera's own ``+X`` (right).
    """
    return rot_y(-heading - math.pi / 2) @ rot_x(pitch)


def projection_from_tangents(
    *, tan_left: float, tan_right: float, tan_up: float, tan_down: float, near: float = NEAR, far: float = FAR
) -> np.ndarray:
    """Off-axis OpenGL projection from the half-angle tangents (``tan_left``, ``tan_down`` < 0 usually).

    Maps the eye-space point ``(tan_right·d, tan_up·d, −d)`` to NDC ``(1, 1)``
    and ``z = −near`` / ``z = −far`` to NDC depth ``−1`` / ``+1``.
    """
    if not (near > 0 and far > near):
        raise ValueError(f"near {near}, far {far}: need 0 < near < far")
    w, h = tan_right - tan_left, tan_up - tan_down
    if w <= 0 or h <= 0:
        raise ValueError(
            f"field of view is empty: tangents l={tan_left} r={tan_right} u={tan_up} d={tan_down}"
        )
    m = np.zeros((4, 4))
    m[0, 0] = 2.0 / w
    m[0, 2] = (tan_right + tan_left) / w
    m[1, 1] = 2.0 / h
    m[1, 2] = (tan_up + tan_down) / h
    m[2, 2] = -(far + near) / (far - near)
    m[2, 3] = -2.0 * far * near / (far - near)
    m[3, 2] = -1.0
    return m


def projection_from_fov(
    *,
    angle_left: float,
    angle_right: float,
    angle_up: float,
    angle_down: float,
    near: float = NEAR,
    far: float = FAR,
) -> np.ndarray:
    """Off-axis projection from an OpenXR ``XrFovf`` (radians; left and down are negative)."""
    return projection_from_tangents(
        tan_left=math.tan(angle_left),
        tan_right=math.tan(angle_right),
        tan_up=math.tan(angle_up),
        tan_down=math.tan(angle_down),
        near=near,
        far=far,
    )


def perspective(*, fovy: float, aspect: float, near: float = NEAR, far: float = FAR) -> np.ndarray:
    """Symmetric projection: vertical field of view ``fovy`` (rad), ``aspect`` = width / height."""
    tu = math.tan(fovy / 2.0)
    return projection_from_tangents(
        tan_left=-tu * aspect, tan_right=tu * aspect, tan_up=tu, tan_down=-tu, near=near, far=far
    )


@dataclass(frozen=True)
class EyeView:
    """One eye: where it is, how it is turned, and its projection.

    ``view`` maps world to eye space; ``projection`` eye to clip space;
    ``position`` is the eye in world space (for lighting and fog).
    """

    view: np.ndarray
    projection: np.ndarray
    position: np.ndarray

    @property
    def view_projection(self) -> np.ndarray:
        return self.projection @ self.view

    @classmethod
    def from_pose(cls, *, rotation: np.ndarray, position: np.ndarray, projection: np.ndarray) -> EyeView:
        return cls(
            view=view_from_pose(rotation, position),
            projection=projection,
            position=np.asarray(position, dtype=np.float64),
        )


def first_person_eye(
    *,
    pos: np.ndarray,
    heading: float,
    pitch: float = 0.0,
    eye_height: float = EYE_HEIGHT,
    fovy: float = math.radians(70.0),
    aspect: float = 16 / 9,
    near: float = NEAR,
    far: float = FAR,
) -> EyeView:
    """The mono first-person eye at the user's eyes (PedVR §3.6), facing ``heading``."""
    r = first_person_rotation(heading, pitch)
    return EyeView.from_pose(
        rotation=r,
        position=ground_to_world(np.asarray(pos), eye_height),
        projection=perspective(fovy=fovy, aspect=aspect, near=near, far=far),
    )


def desktop_stereo_eyes(
    *,
    pos: np.ndarray,
    heading: float,
    pitch: float = 0.0,
    eye_height: float = EYE_HEIGHT,
    ipd: float = IPD,
    fovy: float = math.radians(70.0),
    aspect: float = 16 / 9,
    near: float = NEAR,
    far: float = FAR,
) -> tuple[EyeView, EyeView]:
    """Left and right eyes ``ipd`` apart along the head's right axis, parallel, symmetric frusta.

    With parallel axes a point at depth ``z`` appears ``f·ipd/z`` further right
    in the left image than in the right one (positive disparity, larger for
    near points); this is the desktop preview's stereo (issue 4).
    """
    r = first_person_rotation(heading, pitch)
    centre = ground_to_world(np.asarray(pos), eye_height)
    right = r[:, 0]
    proj = perspective(fovy=fovy, aspect=aspect, near=near, far=far)
    return (
        EyeView.from_pose(rotation=r, position=centre - right * ipd / 2, projection=proj),
        EyeView.from_pose(rotation=r, position=centre + right * ipd / 2, projection=proj),
    )


def overhead_transform(*, center: tuple[float, float], extent: float, aspect: float) -> np.ndarray:
    """3×3 affine map of 2D ground points to NDC for the overhead debug view.

    ``extent`` metres fit the shorter side. A true view from above the 3D
    world (looking down ``−Y``, screen up = 3D ``−Z``): 2D ``+x`` is right and
    2D ``+y`` is *down*, so left and right agree with the first-person view
    (see the chirality note in the module docstring).
    """
    sx, sy = 2.0 / extent, -2.0 / extent
    if aspect >= 1.0:
        sx /= aspect
    else:
        sy *= aspect
    return np.array([[sx, 0, -sx * center[0]], [0, sy, -sy * center[1]], [0, 0, 1]], dtype=np.float64)


def project(view_projection: np.ndarray, p: np.ndarray, *, width: int, height: int) -> np.ndarray:
    """Pixel coordinates ``(col, row from the top)`` of world points ``(..., 3)`` (NaN behind the eye)."""
    p = np.asarray(p, dtype=np.float64)
    h = np.concatenate([p, np.ones(p.shape[:-1] + (1,))], axis=-1) @ view_projection.T
    w = h[..., 3:4]
    ndc = np.where(w > 0, h[..., :3] / np.where(w == 0, 1, w), np.nan)
    col = (ndc[..., 0] + 1) / 2 * width
    row = (1 - (ndc[..., 1] + 1) / 2) * height
    return np.stack([col, row], axis=-1)
