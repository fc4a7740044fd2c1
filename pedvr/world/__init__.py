"""Static geometry: walkable area, navigation mesh, paths, visibility, ray casts."""

from pedvr.world.geometry import edges, obstacle_set, walkable_area
from pedvr.world.navmesh import NavMesh
from pedvr.world.obstacles import ObstacleSet
from pedvr.world.visibility import Visibility

__all__ = ["NavMesh", "ObstacleSet", "Visibility", "edges", "obstacle_set", "walkable_area"]
