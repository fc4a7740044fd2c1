"""View and projection math against closed forms and against pyopenxr's own matrices."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.render.math3d import (
    desktop_stereo_eyes,
    first_person_eye,
    first_person_rotation,
    ground_to_world,
    heading_to_yaw,
    matrix_to_quat,
    perspective,
    project,
    projection_from_fov,
    quat_to_matrix,
    rigid,
    rot_y,
    view_from_pose,
)

HEADINGS = [0.0, 0.3, math.pi / 2, 2.5, -1.2, math.pi]


@pytest.mark.parametrize("theta", HEADINGS)
def test_heading_ccw_from_x_is_yaw_minus_theta_and_the_camera_looks_along_it(theta: float) -> None:
    d = np.array([math.cos(theta), 0.0, math.sin(theta)])  # 2D (cos, sin) -> 3D (x, 0, y)
    assert np.allclose(ground_to_world(np.array([math.cos(theta), math.sin(theta)])), d)
    assert np.allclose(rot_y(heading_to_yaw(theta)) @ [1.0, 0.0, 0.0], d)  # character forward (+X)
    assert np.allclose(first_person_rotation(theta) @ [0.0, 0.0, -1.0], d)  # camera forward (-Z)
    assert np.allclose(first_person_rotation(theta) @ [0.0, 1.0, 0.0], [0, 1, 0])  # no roll


def test_the_3d_world_is_the_2d_plot_mirrored_right_is_heading_plus_90() -> None:
    # Facing 2D +x, 3D right = forward x up = +X x +Y = +Z = 2D +y (the chirality note in math3d).
    right = np.cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    assert np.allclose(right, ground_to_world(np.array([0.0, 1.0])))
    assert np.allclose(rot_y(heading_to_yaw(0.0)) @ [0, 0, 1], right)  # character +Z = its right
    assert np.allclose(first_person_rotation(0.0) @ [1, 0, 0], right)  # the camera's +X = the user's right
    # A growing 2D heading turns the view clockwise seen from above (to the right).
    f0, f1 = first_person_rotation(0.0) @ [0, 0, -1], first_person_rotation(0.1) @ [0, 0, -1]
    assert np.cross(f0, f1)[1] < 0


def test_pitch_looks_up() -> None:
    assert (first_person_rotation(0.0, 0.3) @ [0, 0, -1])[1] == pytest.approx(math.sin(0.3))


@pytest.mark.parametrize("fov", [(-0.9, 0.8, 0.85, -0.95), (-0.7, 0.7, 0.6, -0.6), (-1.0, 0.5, 0.3, -1.1)])
def test_off_axis_projection_maps_the_frustum_corners_and_planes(
    fov: tuple[float, float, float, float],
) -> None:
    left, right, up, down = fov
    near, far = 0.05, 200.0
    p = projection_from_fov(
        angle_left=left, angle_right=right, angle_up=up, angle_down=down, near=near, far=far
    )
    for d in (0.5, 3.0, 40.0):
        for tx, nx in ((math.tan(left), -1), (math.tan(right), 1)):
            for ty, ny in ((math.tan(down), -1), (math.tan(up), 1)):
                c = p @ [tx * d, ty * d, -d, 1.0]
                assert c[:2] / c[3] == pytest.approx([nx, ny], abs=1e-9)
    for z, ndc in ((-near, -1.0), (-far, 1.0)):
        c = p @ [0, 0, z, 1.0]
        assert c[2] / c[3] == pytest.approx(ndc)


def test_symmetric_perspective_is_the_classic_glu_matrix() -> None:
    fovy, aspect, n, f = math.radians(60), 1.5, 0.1, 50.0
    t = 1 / math.tan(fovy / 2)
    expected = np.array(
        [[t / aspect, 0, 0, 0], [0, t, 0, 0], [0, 0, (f + n) / (n - f), 2 * f * n / (n - f)], [0, 0, -1, 0]]
    )
    assert np.allclose(perspective(fovy=fovy, aspect=aspect, near=n, far=f), expected)


@pytest.mark.parametrize("fov", [(-0.9, 0.8, 0.85, -0.95), (-0.7, 0.7, 0.6, -0.6)])
def test_projection_equals_pyopenxr_create_projection_fov(fov: tuple[float, float, float, float]) -> None:
    xr = pytest.importorskip("xr")
    from xr.utils import GraphicsAPI, Matrix4x4f

    xfov = xr.Fovf(angle_left=fov[0], angle_right=fov[1], angle_up=fov[2], angle_down=fov[3])
    theirs = np.asarray(Matrix4x4f.create_projection_fov(GraphicsAPI.OPENGL, xfov, 0.05, 200.0).as_numpy())
    ours = projection_from_fov(
        angle_left=fov[0], angle_right=fov[1], angle_up=fov[2], angle_down=fov[3], near=0.05, far=200.0
    )
    assert np.allclose(ours, theirs, rtol=1e-5, atol=1e-6)


def test_quaternions_match_pyopenxr_and_round_trip() -> None:
    xr = pytest.importorskip("xr")
    from xr.utils import Matrix4x4f

    rng = np.random.default_rng(1)
    for _ in range(5):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        theirs = np.asarray(Matrix4x4f.create_from_quaternion(xr.Quaternionf(*q)).as_numpy())[:3, :3]
        assert np.allclose(quat_to_matrix(*q), theirs, atol=1e-6)
        back = np.asarray(matrix_to_quat(quat_to_matrix(*q)))
        assert np.allclose(back, q) or np.allclose(back, -q)


def test_view_is_the_inverse_of_the_eye_pose() -> None:
    r, p = quat_to_matrix(0.1, 0.7, -0.2, 0.6), np.array([1.0, 1.6, -2.0])
    assert np.allclose(view_from_pose(r, p) @ rigid(r, p), np.eye(4))


def test_desktop_stereo_eyes_are_an_ipd_apart_along_the_right_axis() -> None:
    left, right = desktop_stereo_eyes(pos=np.array([1.0, 2.0]), heading=math.pi / 2, ipd=0.063)
    assert np.linalg.norm(right.position - left.position) == pytest.approx(0.063)
    # Facing 2D +y (3D +z), the right eye is at heading + 90°, i.e. toward 2D -x.
    assert right.position[0] - left.position[0] == pytest.approx(-0.063)
    assert np.allclose(left.projection, right.projection)


def test_project_gives_pixel_rows_from_the_top() -> None:
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.5, aspect=2.0)
    up = project(eye.view_projection, np.array([5.0, 2.0, 0.0]), width=200, height=100)
    down = project(eye.view_projection, np.array([5.0, 1.0, 0.0]), width=200, height=100)
    centre = project(eye.view_projection, np.array([5.0, 1.5, 0.0]), width=200, height=100)
    assert centre == pytest.approx([100, 50])
    assert up[1] < 50 < down[1]
    behind = project(eye.view_projection, np.array([-5.0, 1.5, 0.0]), width=200, height=100)
    assert np.isnan(behind).all()
