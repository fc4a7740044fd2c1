"""Quaternion math and batched forward kinematics as numba kernels.

Quaternions are ``(x, y, z, w)``, scalar last (scipy's and glTF's order),
unit length, and act on column vectors: ``rotate(q, v) = q v q*``. ``qmul(a,
b)`` is "apply ``b`` first, then ``a``". Angles are radians; axes are
right-handed.

3D ↔ 2D (see :mod:`pedvr.scene.config`): a ground point ``(x, y)`` is the 3D
point ``(x, 0, y)``. A body facing 2D heading θ (CCW from +x in 2D) has its
local +Z (forward) along 3D ``(cos θ, 0, sin θ)``; that is the rotation about
+Y by ``φ = π/2 − θ`` (:func:`yaw_quat_from_heading`). The map (x, y) → (x,
0, y) with Y up is a reflection, so a CCW turn in 2D is a *negative*
rotation about +Y in 3D, and the character's anatomical left (local +X) lies
along the 2D direction ``θ − π/2``.

Kernels take their outputs as arguments and allocate nothing per agent.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from pedvr.kernels import row_njit, sincos

# LLVM fast-math flags for every body kernel: fast, but without "reassoc" and "contract", which
# let the compiler reorder sums and fuse multiply-adds differently wherever a function is inlined;
# without them a body's pose is the same bytes whether the pose graph runs it from the serial loop
# or from a parallel chunk (tests/body/test_threads.py).
FASTMATH = {"nnan", "ninf", "nsz", "arcp", "afn"}
_FM = FASTMATH


@njit(cache=True, fastmath=_FM)
def qmul4(ax, ay, az, aw, bx, by, bz, bw):  # type: ignore[no-untyped-def]
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


@njit(cache=True, fastmath=_FM)
def qmul(a, b, out):  # type: ignore[no-untyped-def]
    """``out = a ∘ b`` for 4-vectors (``out`` may alias neither input)."""
    x, y, z, w = qmul4(a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3])
    out[0] = x
    out[1] = y
    out[2] = z
    out[3] = w


@njit(cache=True, fastmath=_FM)
def qrot3(qx, qy, qz, qw, vx, vy, vz):  # type: ignore[no-untyped-def]
    # v + 2 w (u × v) + 2 u × (u × v)
    tx = 2.0 * (qy * vz - qz * vy)
    ty = 2.0 * (qz * vx - qx * vz)
    tz = 2.0 * (qx * vy - qy * vx)
    return (vx + qw * tx + (qy * tz - qz * ty),
            vy + qw * ty + (qz * tx - qx * tz),
            vz + qw * tz + (qx * ty - qy * tx))


@njit(cache=True, fastmath=_FM)
def axis_angle(ax, ay, az, angle, out):  # type: ignore[no-untyped-def]
    """Unit quaternion of ``angle`` about the unit axis ``(ax, ay, az)``."""
    s, c = sincos(0.5 * angle)
    out[0] = ax * s
    out[1] = ay * s
    out[2] = az * s
    out[3] = c


@njit(cache=True, fastmath=_FM)
def euler_yxz4(yaw, pitch, roll):  # type: ignore[no-untyped-def]
    """``R_y(yaw) R_x(pitch) R_z(roll)`` as a quaternion tuple (intrinsic Y, X', Z'')."""
    sy, cy = sincos(0.5 * yaw)
    sp, cp = sincos(0.5 * pitch)
    sr, cr = sincos(0.5 * roll)
    x, y, z, w = qmul4(0.0, sy, 0.0, cy, sp, 0.0, 0.0, cp)
    return qmul4(x, y, z, w, 0.0, 0.0, sr, cr)


@njit(cache=True, fastmath=_FM)
def mat_to_quat(m00, m01, m02, m10, m11, m12, m20, m21, m22, out):  # type: ignore[no-untyped-def]
    """Rotation matrix (row-major entries) to a unit quaternion (Shepperd's method)."""
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        out[3] = 0.25 * s
        out[0] = (m21 - m12) / s
        out[1] = (m02 - m20) / s
        out[2] = (m10 - m01) / s
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0
        out[3] = (m21 - m12) / s
        out[0] = 0.25 * s
        out[1] = (m01 + m10) / s
        out[2] = (m02 + m20) / s
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0
        out[3] = (m02 - m20) / s
        out[0] = (m01 + m10) / s
        out[1] = 0.25 * s
        out[2] = (m12 + m21) / s
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0
        out[3] = (m10 - m01) / s
        out[0] = (m02 + m20) / s
        out[1] = (m12 + m21) / s
        out[2] = 0.25 * s
    n = math.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3])
    for k in range(4):
        out[k] /= n


@njit(cache=True, fastmath=_FM)
def frame_quat(yx, yy, yz, zx, zy, zz, out):  # type: ignore[no-untyped-def]
    """Rotation whose local +Y is the unit ``y`` and local +Z is ``z`` made orthogonal to it."""
    d = zx * yx + zy * yy + zz * yz
    zx -= d * yx
    zy -= d * yy
    zz -= d * yz
    n = math.sqrt(zx * zx + zy * zy + zz * zz)
    if n < 1e-9:  # z parallel to y: pick any perpendicular
        if abs(yx) < 0.9:
            zx, zy, zz = 0.0, -yz, yy  # (1,0,0) × y
        else:
            zx, zy, zz = yz, 0.0, -yx  # (0,1,0) × y
        n = math.sqrt(zx * zx + zy * zy + zz * zz)
    zx /= n
    zy /= n
    zz /= n
    # x = y × z
    xx = yy * zz - yz * zy
    xy = yz * zx - yx * zz
    xz = yx * zy - yy * zx
    mat_to_quat(xx, yx, zx, xy, yy, zy, xz, yz, zz, out)


@njit(cache=True, fastmath=_FM)
def nlerp(a, b, t, out):  # type: ignore[no-untyped-def]
    """Normalized linear interpolation, shortest arc."""
    d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
    s = 1.0 if d >= 0.0 else -1.0
    n = 0.0
    for k in range(4):
        out[k] = (1.0 - t) * a[k] + t * s * b[k]
        n += out[k] * out[k]
    n = math.sqrt(n)
    for k in range(4):
        out[k] /= n


@njit(cache=True, fastmath=_FM)
def yaw_from_heading(theta):  # type: ignore[no-untyped-def]
    """Rotation angle about +Y of a body facing 2D heading ``theta``."""
    return 0.5 * math.pi - theta


@row_njit(fastmath=_FM)
def fk_row(parents, offsets, local_q, rx, ry, rz, root_yaw, pelvis_pos, world_pos, world_q, upto):  # type: ignore[no-untyped-def]
    """Forward kinematics of one body for nodes ``0 .. upto - 1`` (see :func:`fk_kernel`).

    ``offsets (K,3)``, ``local_q (J,4)``, ``pelvis_pos (3,)``; writes ``world_pos (K,3)`` and
    ``world_q (K,4)``. Parents precede children, so any prefix of the nodes is a complete chain.
    """
    nj = local_q.shape[0]
    rqy, rqw = sincos(0.5 * root_yaw)
    for k in range(upto):
        p = parents[k]
        if k < nj:
            lx, ly, lz, lw = local_q[k, 0], local_q[k, 1], local_q[k, 2], local_q[k, 3]
        else:
            lx, ly, lz, lw = 0.0, 0.0, 0.0, 1.0
        if p < 0:
            px, py, pz, pw = 0.0, rqy, 0.0, rqw
            tx, ty, tz = qrot3(px, py, pz, pw, pelvis_pos[0], pelvis_pos[1], pelvis_pos[2])
            ox, oy, oz = rx, ry, rz
        else:
            px, py, pz, pw = world_q[p, 0], world_q[p, 1], world_q[p, 2], world_q[p, 3]
            tx, ty, tz = qrot3(px, py, pz, pw, offsets[k, 0], offsets[k, 1], offsets[k, 2])
            ox, oy, oz = world_pos[p, 0], world_pos[p, 1], world_pos[p, 2]
        world_pos[k, 0] = ox + tx
        world_pos[k, 1] = oy + ty
        world_pos[k, 2] = oz + tz
        x, y, z, w = qmul4(px, py, pz, pw, lx, ly, lz, lw)
        world_q[k, 0] = x
        world_q[k, 1] = y
        world_q[k, 2] = z
        world_q[k, 3] = w


@njit(cache=True, fastmath=_FM)
def fk_kernel(parents, offsets, local_q, root_pos, root_yaw, pelvis_pos, world_pos, world_q):  # type: ignore[no-untyped-def]
    """Batched forward kinematics.

    ``parents (K,)``, ``offsets (N,K,3)`` rest offsets, ``local_q (N,J,4)``
    local rotations of the J joints (end sites have none), ``root_pos
    (N,3)`` the ground root in 3D, ``root_yaw (N,)`` rotation about +Y,
    ``pelvis_pos (N,3)`` the pelvis translation in the root frame (it
    replaces the pelvis rest offset: bob and sway live there). Outputs:
    ``world_pos (N,K,3)``, ``world_q (N,K,4)``.
    """
    nk = parents.shape[0]
    for i in range(local_q.shape[0]):
        fk_row(parents, offsets[i], local_q[i], root_pos[i, 0], root_pos[i, 1], root_pos[i, 2], root_yaw[i],
               pelvis_pos[i], world_pos[i], world_q[i], nk)


@njit(cache=True, fastmath=_FM)
def matrices_kernel(world_pos, world_q, nj, out):  # type: ignore[no-untyped-def]
    """``out (N, nj, 4, 4) float32``: column-vector world transforms ``[R t; 0 1]``."""
    n = world_pos.shape[0]
    for i in range(n):
        for k in range(nj):
            x, y, z, w = world_q[i, k, 0], world_q[i, k, 1], world_q[i, k, 2], world_q[i, k, 3]
            out[i, k, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
            out[i, k, 0, 1] = 2.0 * (x * y - z * w)
            out[i, k, 0, 2] = 2.0 * (x * z + y * w)
            out[i, k, 1, 0] = 2.0 * (x * y + z * w)
            out[i, k, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
            out[i, k, 1, 2] = 2.0 * (y * z - x * w)
            out[i, k, 2, 0] = 2.0 * (x * z - y * w)
            out[i, k, 2, 1] = 2.0 * (y * z + x * w)
            out[i, k, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
            out[i, k, 0, 3] = world_pos[i, k, 0]
            out[i, k, 1, 3] = world_pos[i, k, 1]
            out[i, k, 2, 3] = world_pos[i, k, 2]
            out[i, k, 3, 0] = 0.0
            out[i, k, 3, 1] = 0.0
            out[i, k, 3, 2] = 0.0
            out[i, k, 3, 3] = 1.0


def ground_to_3d(p: np.ndarray, height: np.ndarray | float = 0.0) -> np.ndarray:
    """2D ground points ``(..., 2)`` to 3D ``(..., 3)``: ``(x, y) → (x, h, y)``."""
    p = np.asarray(p, np.float64)
    h = np.broadcast_to(np.asarray(height, np.float64), p.shape[:-1])
    return np.stack([p[..., 0], h, p[..., 1]], axis=-1)


def yaw_quat_from_heading(theta: np.ndarray | float) -> np.ndarray:
    """Quaternions ``(..., 4)`` about +Y of bodies facing 2D heading ``theta`` (see module doc)."""
    phi = 0.5 * np.pi - np.asarray(theta, np.float64)
    out = np.zeros(phi.shape + (4,))
    out[..., 1] = np.sin(0.5 * phi)
    out[..., 3] = np.cos(0.5 * phi)
    return out
