"""The key light and its shadow map's view-projection (pure numpy; the shaders' constants).

One directional key light (the sun outdoors, the main ceiling light
indoors) from :data:`SUN_DIR` (``shaders/common.glsl`` has the same
constant) casts shadows through a square shadow map that covers
``2 · SHADOW_HALF_EXTENT`` metres around the viewer on the ground, seen
along the light; its centre is snapped to whole texels so shadows do not
shimmer as the viewer walks.
"""

from __future__ import annotations

import numpy as np

SUN_DIR = np.array([0.35, 0.85, 0.45]) / np.linalg.norm([0.35, 0.85, 0.45])  # towards the light
SHADOW_HALF_EXTENT = 16.0  # m on each side of the viewer
SHADOW_DEPTH = 120.0  # m: the light's near-to-far range (tall façades included)
SHADOW_MAP_SIZE = 2048


def light_view_projection(center: np.ndarray, *, half_extent: float = SHADOW_HALF_EXTENT,
                          size: int = SHADOW_MAP_SIZE) -> np.ndarray:
    """Orthographic view-projection ``(4, 4)`` of the key light around world point ``center`` (3D).

    Maps the box ``±half_extent`` across the light and ``SHADOW_DEPTH``
    along it (centred on ``center``) to clip space; the centre is snapped to
    the shadow map's texels.
    """
    f = -SUN_DIR  # the light looks along -SUN_DIR
    up = np.array([0.0, 0.0, 1.0]) if abs(f[1]) > 0.99 else np.array([0.0, 1.0, 0.0])
    right = np.cross(f, up)
    right /= np.linalg.norm(right)
    up2 = np.cross(right, f)
    rot = np.stack([right, up2, -f])  # world -> light (rows), camera looks along its -Z
    c = rot @ np.asarray(center, np.float64)
    texel = 2.0 * half_extent / size
    c[:2] = np.floor(c[:2] / texel) * texel
    view = np.eye(4)
    view[:3, :3] = rot
    view[:3, 3] = -c
    view[2, 3] -= SHADOW_DEPTH / 2  # the light's eye sits half the depth range before the centre
    proj = np.eye(4)
    proj[0, 0] = proj[1, 1] = 1.0 / half_extent
    near, far = 0.0, SHADOW_DEPTH
    proj[2, 2] = -2.0 / (far - near)
    proj[2, 3] = -(far + near) / (far - near)
    return proj @ view
