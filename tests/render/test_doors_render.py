"""Doors with moving leaves (issue 4): the leaf is drawn where the door mechanics put it."""

from __future__ import annotations

import math
from collections.abc import Iterator

import moderngl
import numpy as np
import pytest

from pedvr.etiquette.doors import DoorLeaves
from pedvr.render.environment import door_leaf_vertices, environment_mesh, place_leaves
from pedvr.render.math3d import first_person_eye, project
from pedvr.render.overhead import DOOR, frame_geometry
from pedvr.render.renderer import OffscreenTarget, Renderer
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import Door, Obstacle, WorldConfig

W, H = 96, 64


def _wall(x0: float, y0: float, x1: float, y1: float) -> Obstacle:
    return Obstacle(vertices=((x0, y0), (x1, y0), (x1, y1), (x0, y1)), kind="wall", height=2.6)


# A wall across x = 3 with a 1 m doorway at |y| < 0.5 holding a single door hinged at y = -0.5.
DOORWAY = WorldConfig(
    bounds=((-6.0, -6.0), (8.0, 6.0)),
    obstacles=(_wall(2.9, -6.0, 3.1, -0.5), _wall(2.9, 0.5, 3.1, 6.0)),
    doors=(Door(span=((3.0, -0.5), (3.0, 0.5))),),
)


@pytest.fixture(scope="module")
def door_renderer(ctx: moderngl.Context) -> Iterator[Renderer]:
    r = Renderer(ctx, world=DOORWAY, shadows=False)  # where the leaf is, not what it shades
    yield r
    r.release()


def _leaf_pose(angle: float) -> np.ndarray:
    leaves = DoorLeaves.of_world(DOORWAY)
    leaves.angle[:] = angle
    return leaves.pose()


def _render(renderer: Renderer, doors: np.ndarray | None) -> np.ndarray:
    snap = Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0), doors=doors)
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    t = OffscreenTarget(renderer.ctx, (W, H))
    renderer.begin_frame()
    renderer.update(snap)
    renderer.draw_scene([eye], framebuffer=t.fbo)
    img = t.read().astype(np.int32)
    t.release()
    return img


def _doorway_box() -> tuple[slice, slice]:
    """Pixel rows and columns well inside the doorway (0.3 to 1.8 m up, |y| < 0.3), seen from the origin."""
    eye = first_person_eye(pos=np.zeros(2), heading=0.0, eye_height=1.6, aspect=W / H)
    corners = np.array([[3.0, h, y] for h in (0.3, 1.8) for y in (-0.3, 0.3)])
    px = project(eye.view_projection, corners, width=W, height=H)
    cols = slice(int(np.ceil(px[:, 0].min())), int(px[:, 0].max()))
    rows = slice(int(np.ceil(px[:, 1].min())), int(px[:, 1].max()))
    return rows, cols


def test_a_closed_leaf_fills_the_doorway_and_an_open_one_clears_it(door_renderer: Renderer) -> None:
    closed = _render(door_renderer, None)  # no pose: drawn closed
    assert np.array_equal(closed, _render(door_renderer, _leaf_pose(0.0)))
    # The leaf's closed direction is +y, so a negative (clockwise) angle swings it away, toward +x.
    opened = _render(door_renderer, _leaf_pose(math.radians(-90)))
    rows, cols = _doorway_box()
    inside = np.abs(closed[rows, cols] - opened[rows, cols]).max(axis=2) > 12
    assert inside.mean() > 0.9  # the whole doorway changed: the leaf was there and now is not
    # Away from the doorway and the leaf's sweep (the wall's left part), nothing changed.
    assert np.array_equal(closed[:, : cols.start - 12], opened[:, : cols.start - 12])
    # Half open: the leaf still covers part of the doorway.
    half = _render(door_renderer, _leaf_pose(math.radians(-45)))
    part = (np.abs(closed[rows, cols] - half[rows, cols]).max(axis=2) > 12).mean()
    assert 0.1 < part < 0.9


def test_leaf_vertices_turn_about_the_hinge() -> None:
    local = door_leaf_vertices(1.0, 2.1)
    assert local["pos"][:, 0].min() >= 0.0 and local["pos"][:, 0].max() <= 1.0
    placed = place_leaves([local], np.array([[3.0, -0.5, math.pi / 2, 1.0, 2.1]]))
    # Turned to +y in the ground plane: ground y = 3D z from -0.5 to 0.5, ground x stays near 3.
    assert placed["pos"][:, 2].min() >= -0.5 - 1e-6 and placed["pos"][:, 2].max() <= 0.5 + 1e-6
    assert np.abs(placed["pos"][:, 0] - 3.0).max() <= 0.03
    # Normals turned with it, and still unit length.
    np.testing.assert_allclose(np.linalg.norm(placed["normal"], axis=1), 1.0, atol=1e-6)


def test_door_frames_are_static_geometry() -> None:
    without = environment_mesh(WorldConfig(bounds=DOORWAY.bounds, obstacles=DOORWAY.obstacles))
    with_frame = environment_mesh(DOORWAY)
    assert len(with_frame.solids) > len(without.solids)
    extra = with_frame.solids[len(without.solids):]
    # Jambs and a lintel up to the 2.6 m wall over the door.
    assert extra["pos"][:, 1].max() == pytest.approx(2.6)
    assert np.abs(extra["pos"][:, 0] - 3.0).max() < 0.2


def test_overhead_draws_each_leaf_from_hinge_to_tip() -> None:
    pose = _leaf_pose(math.radians(-90))
    snap = Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0), doors=pose)
    lines, _ = frame_geometry(DOORWAY, snap)
    door = lines[np.all(np.isclose(lines["color"], DOOR), axis=1)]
    np.testing.assert_allclose(door["pos"], [[3.0, -0.5], [4.0, -0.5]], atol=1e-6)


def test_a_doors_array_of_the_wrong_shape_is_refused(door_renderer: Renderer) -> None:
    snap = Snapshot.of_agents(pos=np.zeros((0, 2)), heading=np.zeros(0), doors=np.zeros((2, 5)))
    with pytest.raises(ValueError, match=r"doors shape \(2, 5\): expected \(1, 5\)"):
        door_renderer.update(snap)


# A revolving door (issue 14) in the same wall: its four panels are drawn like leaves, turned
# with the door.
REVOLVING = WorldConfig(
    bounds=((-6.0, -6.0), (8.0, 6.0)),
    obstacles=(_wall(2.9, -6.0, 3.1, -1.1), _wall(2.9, 1.1, 3.1, 6.0)),
    doors=(Door(span=((3.0, -1.1), (3.0, 1.1)), kind="revolving"),),
)


def test_revolving_door_panels_are_drawn_where_the_door_has_turned(ctx: moderngl.Context) -> None:
    r = Renderer(ctx, world=REVOLVING, shadows=False)
    try:
        leaves = DoorLeaves.of_world(REVOLVING)
        assert len(leaves) == 4 and leaves.panel.all()
        still = _render(r, leaves.pose())
        leaves.angle[:] = math.radians(45.0)
        turned = _render(r, leaves.pose())
        leaves.angle[:] = math.radians(90.0)  # a quarter turn: the same cross again
        quarter = _render(r, leaves.pose())
    finally:
        r.release()
    rows, cols = _doorway_box()
    changed = (np.abs(still[rows, cols] - turned[rows, cols]).max(axis=2) > 12).mean()
    assert changed > 0.05  # the panels moved across the doorway
    assert np.abs(still - quarter).max() <= 2  # four panels 90 degrees apart look the same
