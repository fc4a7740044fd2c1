"""Warnings about a scene that loads but may not run as its author meant (``pedvr scene check``).

A warning is not a problem: the scene is valid and runs. ``pedvr scene check``
prints each warning as ``FILE: warning: key = value: why`` and still exits 0
when a file has warnings only (2 when it has problems).

:func:`spawn_warnings` (issue 24.1): bodies that start on top of each other.
Two agents placed at the same point, or closer than the sum of their radii,
start overlapping; the contact pass pushes them apart in the first steps (a
jump the participant can see), and coincident centres have no direction to
push along. The user's start counts as a body of ``user.radius`` when the
scene has a user. Agents drawn from a region are placed apart by the
simulation and are not checked here.
"""

from __future__ import annotations

import numpy as np

from pedvr.scene.config import SceneConfig
from pedvr.validation import fmt

COINCIDENT_M = 1e-6  # centres closer than this are "the same point"


def spawn_warnings(scene: SceneConfig) -> list[str]:
    """One line per pair of explicitly placed bodies that start overlapping, in spawn order."""
    from scipy.spatial import cKDTree

    keys: list[str] = []
    pos: list[tuple[float, float]] = []
    rad: list[float] = []
    for i, sp in enumerate(scene.spawns):
        profile = scene.profiles.get(sp.profile)
        if profile is None:
            continue
        for k, p in enumerate(sp.positions):
            keys.append(f"agents.spawns[{i}].positions[{k}]")
            pos.append((float(p[0]), float(p[1])))
            rad.append(profile.radius)
    if scene.user.enabled:
        keys.append("user.start")
        pos.append((float(scene.user.start[0]), float(scene.user.start[1])))
        rad.append(scene.user.radius)
    if len(pos) < 2:
        return []
    xy = np.asarray(pos)
    r = np.asarray(rad)
    pairs = sorted(cKDTree(xy).query_pairs(2.0 * float(r.max())))
    out = []
    for a, b in pairs:
        a, b = (a, b) if keys[a] != "user.start" else (b, a)  # name the agent first
        d = float(np.hypot(*(xy[a] - xy[b])))
        reach = float(r[a] + r[b])
        if d >= reach:
            continue
        other = "the user's start (user.start)" if keys[b] == "user.start" else keys[b]
        if d < COINCIDENT_M:
            why = f"at the same point as {other}: the two bodies start on top of each other"
        else:
            why = (f"{d:.2f} m from {other}, closer than their radii ({r[a]:g} + {r[b]:g} m): "
                   "the two bodies start overlapping")
        out.append(f"{scene.source}: warning: {keys[a]} = {fmt(list(pos[a]))}: {why}")
    return out
