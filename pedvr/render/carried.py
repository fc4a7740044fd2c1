"""What pedestrians carry, drawn: a cardboard box between the hands, a perambulator ahead of the pusher.

Pure numpy (no GL). The shapes are built once in the carrier's body frame from the
body layer's dimensions (:mod:`pedvr.body.carry`: the same frame whose points the hands
reach for, so the hands are on the box's sides and the pram's handle), in the scene
dressing's style (:mod:`pedvr.render.environment`: flat-shaded prisms with the
environment shader's materials). Each frame every carried thing is scaled
(:func:`pedvr.body.carry.object_scale`: a box by its body's scale, a pram not), turned to
its heading and moved to its root, and all of them go into one vertex buffer: one draw
call for every box and pram together, as for the door leaves (a box is 36 vertices, a
pram a few hundred, so even a crowd of carriers is a small upload).

The overhead view draws their outlines (:func:`outline_segments`): the box a square in
front of the disc, the pram its basket's rectangle, its handle and its four wheels.
"""

from __future__ import annotations

import math

import numpy as np

from pedvr.body import carry
from pedvr.render.environment import ENV_DTYPE, FABRIC, METAL, PAINT, _Parts, _prism, linear

CARDBOARD = (0.74, 0.56, 0.34)  # sRGB: a brown cardboard box
PRAM_BODY = (0.16, 0.24, 0.42)  # sRGB: a navy pram basket
PRAM_FRAME = (0.12, 0.12, 0.13)  # sRGB: handle, struts and wheels
WHEEL_WIDTH = 0.045  # m
WHEEL_SIDES = 10


def _cuboid(out: _Parts, a0: float, a1: float, y0: float, y1: float, c0: float, c1: float,
            colour: tuple[float, float, float], material: int) -> None:
    """An axis-aligned box in the body frame (``a`` forward, ``y`` up, ``c`` across)."""
    poly = np.array([[a0, c0], [a1, c0], [a1, c1], [a0, c1]])
    _prism(poly, y0, y1, linear(colour), out, material=material, top=True, bottom=True)


def _wheel(a: float, c: float, radius: float) -> np.ndarray:
    """A wheel at ``(a, radius, c)`` with its axle across: a polygonal disc extruded along ``y``
    and then turned a quarter about the forward axis (``(a, y, c) -> (a, -c, y)``)."""
    out = _Parts()
    ang = np.linspace(0.0, 2.0 * math.pi, WHEEL_SIDES, endpoint=False)
    poly = np.stack([radius * np.cos(ang), radius * np.sin(ang)], axis=1)
    _prism(poly, -WHEEL_WIDTH / 2, WHEEL_WIDTH / 2, linear(PRAM_FRAME), out, material=METAL,
           top=True, bottom=True)
    v = out.verts()
    for key in ("pos", "normal"):
        y, z = v[key][:, 1].copy(), v[key][:, 2].copy()
        v[key][:, 1], v[key][:, 2] = -z, y
    v["pos"] += np.array([a, radius, c], np.float32)
    return v


def box_mesh() -> np.ndarray:
    """The box about its centre, scale 1 (``ENV_DTYPE`` vertices)."""
    d, h, w = carry.BOX_SIZE
    out = _Parts()
    _cuboid(out, -d / 2, d / 2, -h / 2, h / 2, -w / 2, w / 2, CARDBOARD, PAINT)
    return out.verts()


def pram_mesh() -> np.ndarray:
    """The perambulator, body frame, scale 1: basket, handle bar on two posts with struts to the
    basket, four legs and four wheels (``ENV_DTYPE`` vertices)."""
    a0, a1, y0, y1, half = carry.PRAM_BASKET
    ha, hy, hw = carry.PRAM_HANDLE_AHEAD, carry.PRAM_HANDLE_HEIGHT, carry.PRAM_HANDLE_WIDTH / 2
    r = carry.PRAM_WHEEL_RADIUS
    out = _Parts()
    _cuboid(out, a0, a1, y0, y1, -half, half, PRAM_BODY, FABRIC)
    _cuboid(out, a1 - 0.30, a1, y1, y1 + 0.16, -half, half, PRAM_BODY, FABRIC)  # the hood
    _cuboid(out, ha - 0.02, ha + 0.02, hy - 0.02, hy + 0.02, -hw - 0.02, hw + 0.02, PRAM_FRAME, METAL)
    for side in (-1.0, 1.0):
        c = side * (hw - 0.01)
        _cuboid(out, ha - 0.015, ha + 0.015, y1 - 0.06, hy - 0.02, c - 0.015, c + 0.015, PRAM_FRAME, METAL)
        _cuboid(out, ha - 0.015, a0 + 0.01, y1 - 0.08, y1 - 0.04, c - 0.015, c + 0.015, PRAM_FRAME, METAL)
    wheels = []
    for wa in carry.PRAM_AXLES:
        for side in (-1.0, 1.0):
            c = side * (half - WHEEL_WIDTH / 2)
            _cuboid(out, wa - 0.015, wa + 0.015, r, y0, c - 0.015, c + 0.015, PRAM_FRAME, METAL)
            wheels.append(_wheel(wa, c, r))
    return np.concatenate([out.verts(), *wheels])


_MESHES: dict[int, np.ndarray] = {}


def _local(kind: int) -> np.ndarray:
    if kind not in _MESHES:
        _MESHES[kind] = box_mesh() if kind == carry.BOX else pram_mesh()
    return _MESHES[kind]


def frames(kind: np.ndarray, frame: np.ndarray | None, pos: np.ndarray, heading: np.ndarray,
           scale: np.ndarray) -> np.ndarray:
    """``(N, 5)`` the body's carry frames (:func:`pedvr.body.carry.object_frame`), or where none
    were given (a hand-made snapshot) the ones of bodies holding their things at ``pos`` facing
    ``heading``."""
    if frame is not None:
        return np.asarray(frame, np.float64).reshape(-1, carry.FRAME_COLUMNS)
    kind = np.asarray(kind).reshape(-1)
    n = kind.shape[0]
    return carry.object_frame(kind, pos, heading, scale, np.zeros((n, 2, 3)), np.ones((n, 2), np.bool_))


def carried_vertices(kind: np.ndarray, frame: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """World-space vertices of every box and pram: rows with ``kind`` (:data:`pedvr.body.carry.BOX`
    or ``PERAMBULATOR``) placed at ``frame (N, 5)`` (x, y, z, yaw, tilt: :func:`frames`), body
    ``scale (N,)``."""
    kind = np.asarray(kind).reshape(-1)
    frame = np.asarray(frame, np.float64).reshape(-1, carry.FRAME_COLUMNS)
    pos, heading, tilt = frame[:, [0, 2]], frame[:, 3], frame[:, 4]
    scale = carry.object_scale(kind, scale)
    parts = []
    for k in (carry.BOX, carry.PERAMBULATOR):
        rows = np.flatnonzero(kind == k)
        if not rows.size:
            continue
        local = _local(k)
        out = np.tile(local, rows.size).reshape(rows.size, len(local))  # colours, uv, materials
        c, s = np.cos(heading[rows])[:, None], np.sin(heading[rows])[:, None]
        sc = scale[rows][:, None]
        a, y0, c0 = (local["pos"][None, :, j] * sc for j in range(3))
        # the tilt about the forward axis first (its left side, at -c, up), then the heading
        ct, st = np.cos(tilt[rows])[:, None], np.sin(tilt[rows])[:, None]
        y, cc = y0 * ct - c0 * st, c0 * ct + y0 * st
        # (a forward, c across) -> ground: a rotation by the heading (so the winding is kept)
        p = np.empty((rows.size, len(local), 3), np.float32)
        p[..., 0] = c * a - s * cc + pos[rows, 0:1]
        p[..., 1] = y + frame[rows, 1:2]
        p[..., 2] = s * a + c * cc + pos[rows, 1:2]
        na, ny0, nc0 = (local["normal"][None, :, j] for j in range(3))
        ny, nc = ny0 * ct - nc0 * st, nc0 * ct + ny0 * st
        nrm = np.empty_like(p)
        nrm[..., 0] = c * na - s * nc
        nrm[..., 1] = ny
        nrm[..., 2] = s * na + c * nc
        out["pos"] = p
        out["normal"] = nrm
        parts.append(out.reshape(-1))
    return np.concatenate(parts) if parts else np.zeros(0, dtype=ENV_DTYPE)


def outline_segments(kind: np.ndarray, frame: np.ndarray,
                     scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Overhead outlines at ``frame (N, 5)`` (:func:`frames`): segment end points ``(2S, 2)``
    (ground) and each segment's kind ``(S,)``."""
    kind = np.asarray(kind).reshape(-1)
    frame = np.asarray(frame, np.float64).reshape(-1, carry.FRAME_COLUMNS)
    pos, heading = frame[:, [0, 2]], frame[:, 3]
    scale = carry.object_scale(kind, scale)
    d, _, w = carry.BOX_SIZE
    a0, a1, _, _, half = carry.PRAM_BASKET
    ha, hw, r = carry.PRAM_HANDLE_AHEAD, carry.PRAM_HANDLE_WIDTH / 2, carry.PRAM_WHEEL_RADIUS

    def rect(lo: float, hi: float, c: float) -> list[tuple[float, float]]:
        q = [(lo, -c), (hi, -c), (hi, c), (lo, c)]
        return [p for k in range(4) for p in (q[k], q[(k + 1) % 4])]

    handle = [(ha, -hw), (ha, hw), (ha, -hw + 0.01), (a0, -hw + 0.01), (ha, hw - 0.01), (a0, hw - 0.01)]
    wheels = [p for wa in carry.PRAM_AXLES for sd in (-1.0, 1.0)
              for p in ((wa - r, sd * (half + 0.01)), (wa + r, sd * (half + 0.01)))]
    shapes = {carry.BOX: rect(-d / 2, d / 2, w / 2),
              carry.PERAMBULATOR: rect(a0, a1, half) + handle + wheels}
    pts, kinds = [], []
    for k, local in shapes.items():
        rows = np.flatnonzero(kind == k)
        if not rows.size:
            continue
        loc = np.asarray(local)  # (P, 2): (a, c)
        c, s = np.cos(heading[rows])[:, None], np.sin(heading[rows])[:, None]
        sc = scale[rows][:, None]
        x = (c * loc[None, :, 0] - s * loc[None, :, 1]) * sc + pos[rows, 0:1]
        y = (s * loc[None, :, 0] + c * loc[None, :, 1]) * sc + pos[rows, 1:2]
        pts.append(np.stack([x, y], axis=2).reshape(-1, 2))
        kinds.append(np.full(rows.size * len(loc) // 2, k, np.int8))
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, np.int8)
    return np.concatenate(pts), np.concatenate(kinds)
