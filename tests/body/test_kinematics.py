"""Quaternion kernels and forward kinematics against scipy; skeleton proportions; 2D↔3D heading."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from pedvr.body import JOINTS, PARENTS, rest_positions
from pedvr.body import quat as Q
from pedvr.body import skeleton as sk


def _rand_q(rng: np.random.Generator, n: int) -> np.ndarray:
    return Rotation.random(n, random_state=rng).as_quat()  # x, y, z, w


def test_qmul_and_rotate_match_scipy() -> None:
    rng = np.random.default_rng(1)
    a, b = _rand_q(rng, 50), _rand_q(rng, 50)
    v = rng.normal(size=(50, 3))
    out = np.empty(4)
    for k in range(50):
        Q.qmul(a[k], b[k], out)
        ref = (Rotation.from_quat(a[k]) * Rotation.from_quat(b[k])).as_quat()
        assert np.allclose(out * np.sign(out[3]), ref * np.sign(ref[3]), atol=1e-12)
        r = Q.qrot3(*a[k], *v[k])
        assert np.allclose(r, Rotation.from_quat(a[k]).apply(v[k]), atol=1e-12)


def test_euler_axis_angle_and_matrix_to_quat_match_scipy() -> None:
    rng = np.random.default_rng(2)
    out = np.empty(4)
    for _ in range(50):
        y, p, r = rng.uniform(-np.pi, np.pi, 3)
        q = np.array(Q.euler_yxz4(y, p, r))
        ref = Rotation.from_euler("YXZ", [y, p, r]).as_quat()  # intrinsic
        assert np.allclose(q * np.sign(q[3]), ref * np.sign(ref[3]), atol=1e-12)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        ang = rng.uniform(-3, 3)
        Q.axis_angle(*axis, ang, out)
        ref = Rotation.from_rotvec(axis * ang).as_quat()
        assert np.allclose(out * np.sign(out[3]), ref * np.sign(ref[3]), atol=1e-12)
        m = Rotation.from_quat(_rand_q(rng, 1)[0]).as_matrix()
        Q.mat_to_quat(*m.ravel(), out)
        assert np.allclose(Rotation.from_quat(out).as_matrix(), m, atol=1e-12)


def test_frame_quat_axes() -> None:
    rng = np.random.default_rng(3)
    out = np.empty(4)
    for _ in range(30):
        y = rng.normal(size=3)
        y /= np.linalg.norm(y)
        z = rng.normal(size=3)
        Q.frame_quat(*y, *z, out)
        r = Rotation.from_quat(out)
        assert np.allclose(r.apply([0, 1, 0]), y, atol=1e-12)
        zz = z - (z @ y) * y
        assert np.allclose(r.apply([0, 0, 1]), zz / np.linalg.norm(zz), atol=1e-12)


def _fk_reference(offsets: np.ndarray, local_q: np.ndarray, root: np.ndarray, yaw: float,
                  pelvis: np.ndarray) -> np.ndarray:
    """An independent FK with scipy rotations."""
    k = len(PARENTS)
    rot: list[Rotation] = []
    pos = np.zeros((k, 3))
    root_r = Rotation.from_rotvec([0.0, yaw, 0.0])
    for j in range(k):
        local = Rotation.from_quat(local_q[j]) if j < len(JOINTS) else Rotation.identity()
        p = PARENTS[j]
        if p < 0:
            pos[j] = root + root_r.apply(pelvis)
            rot.append(root_r * local)
        else:
            pos[j] = pos[p] + rot[p].apply(offsets[j])
            rot.append(rot[p] * local)
    return pos


def test_batched_fk_matches_scipy() -> None:
    rng = np.random.default_rng(4)
    n = 5
    dims = sk.draw_dims(rng, n)
    off = sk.dims_offsets(dims)
    lq = Rotation.random(n * sk.J, random_state=rng).as_quat().reshape(n, sk.J, 4)
    root = rng.normal(size=(n, 3))
    yaw = rng.uniform(-3, 3, n)
    pelvis = rng.normal(size=(n, 3))
    wp = np.empty((n, sk.K, 3))
    wq = np.empty((n, sk.K, 4))
    Q.fk_kernel(sk.PARENTS, off, lq, root, yaw, pelvis, wp, wq)
    for i in range(n):
        assert np.allclose(wp[i], _fk_reference(off[i], lq[i], root[i], yaw[i], pelvis[i]), atol=1e-10)
    mats = np.empty((n, sk.J, 4, 4), np.float32)
    Q.matrices_kernel(wp, wq, sk.J, mats)
    r = Rotation.from_quat(wq[:, :sk.J].reshape(-1, 4)).as_matrix().reshape(n, sk.J, 3, 3)
    assert np.allclose(mats[..., :3, :3], r, atol=1e-6)
    assert np.allclose(mats[..., :3, 3], wp[:, :sk.J], atol=1e-5)


def test_heading_maps_to_rotation_about_y() -> None:
    """2D heading θ (CCW from +x) → rotation π/2 − θ about +Y; forward +Z lands on (cos θ, 0, sin θ)."""
    for theta in np.linspace(-np.pi, np.pi, 13):
        r = Rotation.from_quat(Q.yaw_quat_from_heading(theta))
        assert np.allclose(r.apply([0, 0, 1]), [np.cos(theta), 0, np.sin(theta)], atol=1e-12)
        # the character's left (+X) is the 2D direction θ − π/2
        left = r.apply([1, 0, 0])
        assert np.allclose(left, [np.cos(theta - np.pi / 2), 0, np.sin(theta - np.pi / 2)], atol=1e-12)
    # a CCW turn in 2D is a negative rotation about +Y
    a, b = Q.yaw_quat_from_heading(0.0), Q.yaw_quat_from_heading(0.3)
    rel = Rotation.from_quat(b) * Rotation.from_quat(a).inv()
    assert np.allclose(rel.as_rotvec(), [0, -0.3, 0], atol=1e-12)
    assert np.allclose(Q.ground_to_3d(np.array([1.0, 2.0]), 0.5), [1.0, 0.5, 2.0])


def test_skeleton_proportions_and_scaling() -> None:
    assert len(JOINTS) == 26 and len(sk.NODES) == 33
    assert all(PARENTS[k] < k for k in range(len(PARENTS)))
    ref = rest_positions(sk.user_dims(1))[0]
    assert abs(ref[sk.L_HIP, 1] - 0.93) < 0.01
    assert abs(ref[sk.L_EYE, 1] - 1.64) < 0.01
    assert abs(ref[sk.HEAD_TOP, 1] - 1.75) < 0.01
    assert abs((ref[sk.L_SHOULDER, 0] - ref[sk.R_SHOULDER, 0]) - 0.45) < 0.01
    assert abs(ref[sk.L_HEEL, 1]) < 1e-9 and abs(ref[sk.L_TOE_TIP, 1]) < 1e-9  # soles on the floor
    dims = sk.draw_dims(np.random.default_rng(0), 2000)
    assert dims[:, sk.DIM_HEIGHT].min() >= 1.55 and dims[:, sk.DIM_HEIGHT].max() <= 1.95
    tall = rest_positions(np.array([[1.95, 0, 0.5, 1.95 / 1.75]]))[0]
    assert abs(tall[sk.HEAD_TOP, 1] - 1.95) < 0.01
    f = rest_positions(np.array([[1.75, 1, 0.5, 1.0]]))[0]
    assert (f[sk.L_SHOULDER, 0] - f[sk.R_SHOULDER, 0]) < (ref[sk.L_SHOULDER, 0] - ref[sk.R_SHOULDER, 0])


def test_shoulder_turn_turns_the_chest_not_the_hips_or_the_head() -> None:
    """``state.shoulder_turn`` (set by the simulation each step) yaws the upper torso relative to the pelvis;
    legs, pelvis and the head's facing are as without it, and 0 changes nothing."""
    from tests.body._walk import bodies, drive

    def pose(turn: float) -> np.ndarray:
        b = bodies(1, seed=2)
        b.state.shoulder_turn[:] = turn
        drive(b, lambda t: np.array([[1.2, 0.0]]), lambda t: np.zeros(1), 1.5)
        return b.state.world_pos[0].copy(), b.state.world_q[0].copy()

    still, still_q = pose(0.0)
    turned, turned_q = pose(0.6)
    legs = [sk.PELVIS, sk.L_HIP, sk.L_KNEE, sk.L_ANKLE, sk.R_HIP, sk.R_KNEE, sk.R_ANKLE, sk.L_HEEL, sk.R_HEEL]
    np.testing.assert_array_equal(turned[legs], still[legs])

    def yaw(a: np.ndarray, b: np.ndarray) -> float:  # 3D heading of the line a -> b about +Y
        d = b - a
        return float(np.arctan2(d[0], d[2]))

    chest = yaw(turned[sk.R_SHOULDER], turned[sk.L_SHOULDER]) - yaw(still[sk.R_SHOULDER], still[sk.L_SHOULDER])
    hips = yaw(turned[sk.R_HIP], turned[sk.L_HIP]) - yaw(still[sk.R_HIP], still[sk.L_HIP])
    assert abs(chest - 0.6) < 0.08 and hips == 0.0
    # the head still faces where it did: its forward axis turns by less than 1°
    fwd = Rotation.from_quat(turned_q[sk.HEAD]).apply([0.0, 0.0, 1.0])
    ref = Rotation.from_quat(still_q[sk.HEAD]).apply([0.0, 0.0, 1.0])
    assert abs(np.arctan2(fwd[0], fwd[2]) - np.arctan2(ref[0], ref[2])) < np.radians(1.0)
    unchanged, _ = pose(0.0)
    np.testing.assert_array_equal(unchanged, still)
