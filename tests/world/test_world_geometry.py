import numpy as np
import pytest
import shapely
from _world_helpers import box_obstacle

from pedvr.errors import NavigationError
from pedvr.scene.config import Obstacle, WorldConfig
from pedvr.world import obstacle_set, walkable_area
from pedvr.world.geometry import edges


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _rings(obs):
    """Split an ObstacleSet back into its vertex chains."""
    seen = np.zeros(len(obs), bool)
    rings = []
    for k in range(len(obs)):
        if seen[k]:
            continue
        chain = [k]
        seen[k] = True
        j = obs.next[k]
        while j != k:
            chain.append(j)
            seen[j] = True
            j = obs.next[j]
        rings.append(obs.vertices[chain])
    return rings


def test_walkable_area_is_bounds_minus_union_of_obstacles():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(2, 2, 4, 4), box_obstacle(3, 3, 5, 5)))
    area = walkable_area(world)
    assert area.area == pytest.approx(100 - 4 - 4 + 1)


def test_obstacle_set_orientation_and_merging_of_overlapping_boxes():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(2, 2, 4, 4), box_obstacle(3, 3, 5, 5)))
    rings = _rings(obstacle_set(world))
    assert len(rings) == 2  # the room outline and ONE merged obstacle
    outer = [r for r in rings if len(r) == 4]
    hole = [r for r in rings if len(r) == 8]  # the union of two overlapping boxes has 8 corners
    assert len(outer) == 1 and len(hole) == 1
    assert _signed_area(outer[0]) == pytest.approx(-100.0)  # exterior clockwise
    assert _signed_area(hole[0]) == pytest.approx(7.0)  # obstacle counter-clockwise


def test_obstacle_touching_border_becomes_part_of_outer_ring():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(-1, 4, 3, 6),))
    rings = _rings(obstacle_set(world))
    assert len(rings) == 1
    assert len(rings[0]) == 8  # room with a notch, no collinear leftovers
    assert _signed_area(rings[0]) == pytest.approx(-(100 - 6))


def test_obstacle_set_convexity_of_room_and_obstacle():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(2, 2, 4, 4),))
    obs = obstacle_set(world)
    # RVO2: box corners are convex (the CCW chain turns left); the room's
    # corners are not (the CW boundary turns right there).
    in_room_corner = np.isin(obs.vertices, [0.0, 10.0]).all(axis=1)
    assert in_room_corner.sum() == 4
    assert not obs.convex[in_room_corner].any()
    assert obs.convex[~in_room_corner].all()


def test_edges_match_the_walkable_boundary():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(2, 2, 4, 4), box_obstacle(6, 6, 8, 9)))
    p1, p2 = edges(world)
    assert p1.shape == p2.shape == (12, 2)
    total = float(np.linalg.norm(p2 - p1, axis=1).sum())
    assert total == pytest.approx(walkable_area(world).boundary.length)
    lines = shapely.linestrings(np.stack([p1, p2], axis=1))
    assert shapely.covers(walkable_area(world).boundary.buffer(1e-9), lines).all()


def test_degenerate_obstacle_is_named():
    world = WorldConfig(((0, 0), (10, 10)), (box_obstacle(1, 1, 2, 2), Obstacle(((1, 1), (2, 2)))))
    with pytest.raises(NavigationError, match=r"world\.obstacles\[1\]"):
        walkable_area(world)


def test_empty_bounds_rejected():
    with pytest.raises(NavigationError, match="world.bounds"):
        walkable_area(WorldConfig(((0, 0), (0, 10))))
