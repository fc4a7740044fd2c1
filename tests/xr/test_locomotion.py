"""Keyboard and mouse: walking speed, Shift, strafing to the right in 3D, mouse look, walls."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pedvr.render.math3d import first_person_rotation, ground_to_world
from pedvr.scene.config import Obstacle, WorldConfig
from pedvr.xr.locomotion import KeyboardMouseUser, WalkableArea

WORLD = WorldConfig(
    bounds=((-5.0, -5.0), (5.0, 5.0)),
    obstacles=(
        Obstacle(vertices=((2.0, -1.0), (3.0, -1.0), (3.0, 1.0), (2.0, 1.0)), kind="wall", height=2.5),
    ),
)


def walk(user: KeyboardMouseUser, seconds: float, dt: float = 1 / 90) -> np.ndarray:
    user.pose(0.0)
    for k in range(1, round(seconds / dt) + 1):
        pos, _ = user.pose(k * dt)
    return pos


def test_w_walks_forward_at_1_3_mps_and_shift_doubles_it() -> None:
    u = KeyboardMouseUser(start=(0.0, 0.0), heading=math.pi / 2)
    u.set_keys(forward=1, strafe=0, fast=False)
    assert walk(u, 1.0) == pytest.approx([0.0, 1.3])
    v = KeyboardMouseUser(start=(0.0, 0.0), heading=0.0)
    v.set_keys(forward=1, strafe=0, fast=True)
    assert walk(v, 1.0) == pytest.approx([2.6, 0.0])


def test_diagonals_are_not_faster_and_d_strafes_to_the_cameras_right() -> None:
    u = KeyboardMouseUser(start=(0.0, 0.0), heading=0.0)
    u.set_keys(forward=0, strafe=1, fast=False)
    pos = walk(u, 1.0)
    camera_right = first_person_rotation(0.0) @ [1.0, 0.0, 0.0]
    assert ground_to_world(pos) == pytest.approx(1.3 * camera_right)
    d = KeyboardMouseUser(start=(0.0, 0.0), heading=0.0)
    d.set_keys(forward=1, strafe=1, fast=False)
    assert np.linalg.norm(walk(d, 1.0)) == pytest.approx(1.3)


def test_mouse_look_turns_right_and_pitch_is_clamped() -> None:
    u = KeyboardMouseUser(start=(0.0, 0.0), heading=0.0)
    u.look(yaw=0.2, pitch=5.0)
    f0, f1 = first_person_rotation(0.0) @ [0, 0, -1], first_person_rotation(u.heading) @ [0, 0, -1]
    assert np.cross(f0, f1)[1] < 0  # clockwise seen from above: to the right
    assert u.pitch == pytest.approx(math.radians(85))


def test_walls_stop_the_user_and_it_slides_along_them() -> None:
    area = WalkableArea(WORLD, radius=0.25)
    u = KeyboardMouseUser(start=(0.0, 0.0), heading=0.0, walkable=area)
    u.set_keys(forward=1, strafe=0, fast=False)
    pos = walk(u, 3.0)
    assert pos[0] == pytest.approx(1.75, abs=0.02)  # wall face at x = 2, minus the radius
    u2 = KeyboardMouseUser(start=(0.0, -0.5), heading=math.atan2(0.4, 1.0), walkable=area)
    u2.set_keys(forward=1, strafe=0, fast=False)
    pos2 = walk(u2, 3.0)
    assert pos2[0] <= 1.76 and pos2[1] > 0.5  # slid along the wall
