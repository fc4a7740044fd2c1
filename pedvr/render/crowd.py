"""The CPU side of drawing the crowd: looks, skinning matrices, levels of detail, blinks (no GL).

Per frame the renderer needs, for every drawn agent, its skinning matrices
(:func:`skin_rows`, a numba kernel writing straight into the texture's
layout), its looks (:func:`agent_looks`: colours and garments, drawn once from
the agent's stable id and its body dims) with the blink of the moment
(:class:`Blinks`), and which character and level of detail draws it
(:func:`lod_levels`, :func:`draw_plan`). Everything here is deterministic in the agent ids and
the snapshot's time.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np

from pedvr.body import JOINTS, rest_positions
from pedvr.body import skeleton as sk

N_JOINTS = len(JOINTS)
SKIN_TEXELS = 3 * N_JOINTS  # rows of each bone's 3×4 skinning matrix
LOOK_TEXELS = 8


def _srgb(hexes: tuple[str, ...]) -> np.ndarray:
    rgb = np.array([[int(h[i:i + 2], 16) / 255.0 for i in (0, 2, 4)] for h in hexes])
    return np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)  # to linear


# The Monk Skin Tone scale (Monk 2019; ten tones, lightest to darkest), linear RGB.
SKIN_TONES = _srgb(("f6ede4", "f3e7db", "f7ead0", "eadaba", "d7bd96", "a07e56", "825c43", "604134",
                    "3a312a", "292420"))
HAIR_COLOURS = _srgb(("1c1714", "2b1e16", "3d2a1c", "5a3c24", "8a6440", "b89668", "7a3b20", "8e8a86",
                      "15110f"))
IRIS_COLOURS = _srgb(("3b2414", "5a3a20", "6f5a2e", "4d6a3c", "4f7aa0", "70808c"))
TOPS = _srgb(("c0392b", "2e5e9e", "3f7f4f", "e0b040", "7d3f8c", "e8e6e0", "2a2a30", "e07b28", "4ea0a8",
              "8a6a4a", "b04060", "f0d0c0", "33465a", "6b7f3a"))
BOTTOMS = _srgb(("24304f", "3b3b40", "6a5846", "151517", "74767f", "4a3626", "2c3e5c", "8b7d6b"))
SHOES = _srgb(("151515", "3b2516", "e8e8e8", "55565a", "1d2a44", "6b4a2e"))


def _hash01(ids: np.ndarray, salt: int) -> np.ndarray:
    """Uniform [0, 1) per id (splitmix64), stable across runs and platforms."""
    with np.errstate(over="ignore"):
        z = np.asarray(ids, dtype=np.uint64) + np.uint64(salt) * np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def _pick(table: np.ndarray, u: np.ndarray) -> np.ndarray:
    return table[np.minimum((u * len(table)).astype(np.int64), len(table) - 1)]


def _weighted(u: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Index drawn per row of ``weights (N, K)`` with the uniform ``u (N,)``."""
    c = np.cumsum(weights, axis=1)
    c /= c[:, -1:]
    return np.minimum((u[:, None] >= c).sum(axis=1), weights.shape[1] - 1)


@dataclass(frozen=True)
class Looks:
    """Per-agent appearance, rows aligned with the ids it was drawn for.

    Colours are linear RGB ``(N, 3)``. ``sleeve`` and ``trouser`` are the
    fractions of the arm (shoulder to wrist) and leg (hip to ankle) the top
    and the trousers cover; ``hem`` the height (m, bind pose of the 1.75 m
    adult) where the top meets the trousers or skirt; ``hair_style`` indexes
    :data:`~pedvr.render.bodymesh.HAIR_STYLES`; ``skirt`` whether the agent
    wears one; ``tone`` the skin tone's index on the Monk scale (0 lightest).
    """

    skin: np.ndarray
    top: np.ndarray
    bottom: np.ndarray
    shoes: np.ndarray
    hair: np.ndarray
    iris: np.ndarray
    sleeve: np.ndarray
    trouser: np.ndarray
    hem: np.ndarray
    hair_style: np.ndarray
    skirt: np.ndarray
    tone: np.ndarray


def agent_looks(ids: np.ndarray, dims: np.ndarray) -> Looks:
    """Looks drawn from each agent's stable id and its body (sex from ``dims``, body layer columns).

    Skin tones are uniform over the ten Monk tones (a wide, realistic range:
    issue 16), hair and eye colours lean dark for darker tones, hair styles
    and skirts depend on sex. The same id and dims give the same looks on
    every run.
    """
    ids = np.asarray(ids, np.int64)
    n = len(ids)
    female = np.asarray(dims, np.float64).reshape(n, sk.N_DIMS)[:, sk.DIM_SEX] > 0.5
    u = [_hash01(ids, 100 + k) for k in range(14)]
    tone = np.minimum((u[0] * len(SKIN_TONES)).astype(np.int64), len(SKIN_TONES) - 1)
    skin = SKIN_TONES[tone] * (0.94 + 0.12 * u[1])[:, None]
    dark = tone / (len(SKIN_TONES) - 1)
    hair_w = np.ones((n, len(HAIR_COLOURS)))
    hair_w[:, :4] += 3.0 * dark[:, None]  # black and dark browns
    hair_w[:, 7] = np.where(u[2] < 0.15, 3.0, 0.3)  # some grey
    hair = HAIR_COLOURS[_weighted(u[3], hair_w)]
    iris_w = np.ones((n, len(IRIS_COLOURS)))
    iris_w[:, :2] += 8.0 * dark[:, None]
    iris = IRIS_COLOURS[_weighted(u[4], iris_w)]
    style_w = np.where(female[:, None], np.array([[0.1, 0.4, 0.2, 0.05, 0.25]]),
                       np.array([[0.5, 0.05, 0.03, 0.32, 0.1]]))
    hair_style = _weighted(u[5], style_w)
    skirt = female & (u[6] < 0.35)
    trouser = np.where(skirt, 0.0, np.where(u[7] < 0.1, 0.42, 1.0))
    sleeve = np.where(u[8] < 0.45, 0.3, 0.97)
    hem = 0.95 + 0.06 * u[9]
    return Looks(skin=skin, top=_pick(TOPS, u[10]), bottom=_pick(BOTTOMS, u[11]), shoes=_pick(SHOES, u[12]),
                 hair=hair, iris=iris, sleeve=sleeve, trouser=trouser, hem=hem, hair_style=hair_style,
                 skirt=skirt, tone=tone)


def look_rows(looks: Looks, dims: np.ndarray, blink: np.ndarray) -> np.ndarray:
    """The looks texture's rows ``(N, LOOK_TEXELS, 4) float32`` (the layout ``crowd.glsl`` reads)."""
    n = len(looks.skin)
    out = np.zeros((n, LOOK_TEXELS, 4), np.float32)
    d = np.asarray(dims, np.float64).reshape(n, sk.N_DIMS)
    for k, (rgb, a) in enumerate(((looks.skin, looks.sleeve), (looks.top, looks.trouser),
                                  (looks.bottom, looks.hem), (looks.shoes, looks.hair_style),
                                  (looks.hair, looks.skirt), (looks.iris, blink))):
        out[:, k, :3], out[:, k, 3] = rgb, a
    out[:, 6, 0] = d[:, sk.DIM_SEX]
    out[:, 6, 1] = d[:, sk.DIM_BUILD] - 0.5
    return out


def bind_joints(dims: np.ndarray) -> np.ndarray:
    """Bind-pose joint positions ``(N, 26, 3)`` at the reference height for each agent's sex and build."""
    d = np.array(dims, np.float64).reshape(-1, sk.N_DIMS)
    d[:, sk.DIM_SCALE] = 1.0
    d[:, sk.DIM_HEIGHT] = sk.REFERENCE_HEIGHT
    return rest_positions(d)[:, :N_JOINTS]


@numba.njit(cache=True)
def skin_rows(world: np.ndarray, rows: np.ndarray, scale: np.ndarray, rest: np.ndarray,
              out: np.ndarray) -> None:
    """Skinning matrices of agents ``rows`` of ``world (N, 26, 4, 4)`` into ``out (len(rows), 78, 4)``.

    Joint ``j`` of an agent drawn at scale ``s`` with bind-pose joints
    ``rest (len(rows), 26, 3)``: ``M = [s·R | p − s·R·r]`` (the body's bind pose
    has identity rotations, DESIGN.md "body"), written as the three rows of
    the 3×4 matrix.
    """
    for a in range(rows.shape[0]):
        i = rows[a]
        s = scale[a]
        for j in range(world.shape[1]):
            for k in range(3):
                r0 = s * world[i, j, k, 0]
                r1 = s * world[i, j, k, 1]
                r2 = s * world[i, j, k, 2]
                o = 3 * j + k
                out[a, o, 0] = r0
                out[a, o, 1] = r1
                out[a, o, 2] = r2
                rr = r0 * rest[a, j, 0] + r1 * rest[a, j, 1] + r2 * rest[a, j, 2]
                out[a, o, 3] = world[i, j, k, 3] - rr


# Levels of detail by what they would change on screen (issue 27): a level is good enough for an
# agent when its surface's largest deviation from level 0's (CharacterMesh.lod_error, metres)
# subtends at most LOD_TOLERANCE_PX pixels of the view at the agent's distance. For the procedural
# character (deviations 3.0, 6.1, 10.6 and 18.7 mm: bodymesh.PROCEDURAL_LOD_ERROR) in the desktop's
# 70° view 1600 pixels high (1142 pixels per radian) that is level 1 from 3.4 m, level 2 from 7.0 m,
# level 3 from 12.1 m and level 4 from 21.4 m; a headset's wider view has fewer pixels per radian
# and brings them nearer (at 100°, 1600 pixels high: 2.0, 4.1, 7.1 and 12.5 m).
LOD_TOLERANCE_PX = 1.0


def lod_levels(pos: np.ndarray, viewer: np.ndarray, *, pixels_per_radian: float,
               errors: Sequence[float]) -> np.ndarray:
    """Level of detail ``(N,) int64`` of agents at ground points ``pos (N, 2)`` seen from ``viewer`` (2D).

    ``errors``: each level's largest deviation (m) from level 0 (``CharacterMesh.lod_error``).
    ``pixels_per_radian``: the view's resolution at its centre (:func:`pixels_per_radian`). Each
    agent gets the coarsest level whose error subtends at most :data:`LOD_TOLERANCE_PX` at its
    ground distance (never more than the eye's distance to the body, so this errs on the fine side).
    """
    d = np.hypot(pos[:, 0] - viewer[0], pos[:, 1] - viewer[1])
    # Level k will do beyond errors[k] · pixels / tolerance (a coarser level never before a finer one).
    e = np.maximum.accumulate(np.asarray(errors, np.float64))[1:]
    beyond = e * max(float(pixels_per_radian), 0.0) / LOD_TOLERANCE_PX
    return np.searchsorted(beyond, d, side="right").astype(np.int64)


# The key light's shadow map draws each character at the coarsest level that deviates from level 0
# by at most SHADOW_LOD_TEXELS of the map's texels: its 3×3 filter taps 1.5 texels apart
# (shaders/common.glsl) blur the edge over 4.5 texels, so a deviation under 2 moves no edge by more
# than the filter does. At the default 2048 texels over 32 m (1.6 cm each) that is the procedural
# character's coarsest level (18.7 mm against 31 mm).
SHADOW_LOD_TEXELS = 2.0


def shadow_level(errors: Sequence[float], texel: float) -> int:
    """The coarsest level whose deviation ``errors[k]`` (m) is within :data:`SHADOW_LOD_TEXELS`
    shadow-map texels of ``texel`` metres (0 when none is)."""
    e = np.maximum.accumulate(np.asarray(errors, np.float64))
    return int(np.flatnonzero(e <= SHADOW_LOD_TEXELS * texel).max(initial=0))


def pixels_per_radian(projection: np.ndarray, viewport_height: int) -> float:
    """Pixels per radian at the centre of a view whose projection is ``projection`` (OpenGL, 4×4),
    drawn ``viewport_height`` pixels high: the vertical focal length in pixels."""
    return float(projection[1, 1]) * viewport_height / 2.0


# A sphere that holds an agent whatever its pose (issue 27: agents outside every eye's view are not
# drawn): centred BOUND_CENTRE · scale above its ground point, BOUND_RADIUS · scale + BOUND_MARGIN
# across. At the 1.75 m reference the head's top is 0.85 m from the centre, a raised hand 1.3 m, a
# foot a stride ahead 1.1 m; the margin covers the pose's root straying from the snapshot's ground
# point (the body's coupling) and a held object's reach.
BOUND_CENTRE = 0.9  # m at scale 1
BOUND_RADIUS = 1.3  # m at scale 1
BOUND_MARGIN = 0.3  # m


def in_views(pos: np.ndarray, scale: np.ndarray, view_projections: Sequence[np.ndarray]) -> np.ndarray:
    """``(N,) bool``: which agents at ground points ``pos (N, 2)`` (world x and z) with height scale
    ``scale (N,)`` may show in any of the views (world-to-clip matrices, OpenGL convention): their
    bounding sphere is not wholly outside one of the view's six frustum planes (Gribb and
    Hartmann's planes from the matrix's rows). Conservative: a sphere beyond a frustum's corner
    counts as seen."""
    pos = np.asarray(pos, np.float64).reshape(-1, 2)
    scale = np.asarray(scale, np.float64)
    centre = np.stack([pos[:, 0], BOUND_CENTRE * scale, pos[:, 1], np.ones(len(pos))], axis=1)
    radius = BOUND_RADIUS * scale + BOUND_MARGIN
    seen = np.zeros(len(pos), np.bool_)
    for m in view_projections:
        m = np.asarray(m, np.float64)
        planes = np.stack([m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]])
        planes /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
        seen |= (centre @ planes.T >= -radius[:, None]).all(axis=1)
    return seen


@dataclass(frozen=True)
class Piece:
    """One variant's triangles in a level of detail's index buffer as :func:`mesh_pieces` orders it.

    ``variant`` is the vertices' (``bodymesh.ALWAYS``, a hair style, ``bodymesh.SKIRT_VARIANT``);
    ``first`` and ``indices`` the range in the index buffer (3 per triangle); ``vertices`` how
    many distinct vertices the triangles use (how often the vertex shader runs per instance).
    """

    variant: int
    first: int
    indices: int
    vertices: int


def mesh_pieces(triangles: np.ndarray, variant: np.ndarray) -> tuple[np.ndarray, tuple[Piece, ...]]:
    """The triangles ``(T, 3)`` ordered by their vertices' ``variant`` (always-worn first, stable
    within a variant) and the pieces of that order; a triangle across variants is an error."""
    t = np.asarray(triangles, np.int64).reshape(-1, 3)
    var = np.asarray(variant, np.int64)[t]
    if t.size and not (var == var[:, :1]).all():
        bad = int(np.flatnonzero((var != var[:, :1]).any(axis=1))[0])
        raise ValueError(f"triangle {bad} joins vertices of variants {sorted(set(var[bad].tolist()))}")
    tv = var[:, 0] if t.size else np.zeros(0, np.int64)
    order = np.argsort(tv, kind="stable")
    t, tv = t[order], tv[order]
    pieces = []
    for v in np.unique(tv):
        rows = np.flatnonzero(tv == v)
        pieces.append(Piece(variant=int(v), first=3 * int(rows[0]), indices=3 * len(rows),
                            vertices=len(np.unique(t[rows]))))
    return t.astype(np.uint32), tuple(pieces)


@dataclass(frozen=True)
class Draw:
    """One instanced draw of the crowd: piece ``piece`` of ``character``'s level ``level`` for the
    agents in columns ``first`` to ``first + count`` of row ``row`` of the instance order."""

    character: int
    level: int
    piece: int
    row: int
    first: int
    count: int


ORDER_ROWS = 2  # row 0: by (character, level, skirt); row 1: by (character, level, hair style)


def draw_plan(character: np.ndarray, lod: np.ndarray, hair_style: np.ndarray, skirt: np.ndarray,
              pieces: list[list[tuple[Piece, ...]]], *, always: int, skirt_variant: int
              ) -> tuple[np.ndarray, list[Draw]]:
    """The instance order ``(ORDER_ROWS, N) int32`` and the draws that give every agent the pieces
    it wears, and only those: the always-worn piece of its character and level, the hair style's
    piece, the skirt if it wears one.

    ``pieces[c][l]``: character ``c``'s level ``l`` (:func:`mesh_pieces`); a piece's variant is
    ``always``, ``skirt_variant`` or a hair style's index. Draws per frame are bounded by the
    characters, levels and pieces, whatever the number of agents.
    """
    character = np.asarray(character, np.int64)
    lod = np.asarray(lod, np.int64)
    style = np.asarray(hair_style, np.int64)
    skirted = np.asarray(skirt, np.bool_).astype(np.int64)
    levels = max((len(p) for p in pieces), default=1)
    styles = int(style.max()) + 1 if style.size else 1
    group = character * levels + lod
    keys = (group * 2 + skirted, group * styles + style)
    order = np.zeros((ORDER_ROWS, len(group)), np.int32)
    starts, counts = [], []
    for row, key in enumerate(keys):
        order[row] = np.argsort(key, kind="stable")
        n = np.bincount(key, minlength=len(pieces) * levels * (2 if row == 0 else styles))
        counts.append(n)
        starts.append(np.cumsum(n) - n)
    draws = []
    for c, per_level in enumerate(pieces):
        for level, level_pieces in enumerate(per_level):
            g = c * levels + level
            for k, piece in enumerate(level_pieces):
                if piece.variant == always:
                    row, first, count = 0, starts[0][2 * g], counts[0][2 * g] + counts[0][2 * g + 1]
                elif piece.variant == skirt_variant:
                    row, first, count = 0, starts[0][2 * g + 1], counts[0][2 * g + 1]
                elif 0 <= piece.variant < styles:
                    key = g * styles + piece.variant
                    row, first, count = 1, starts[1][key], counts[1][key]
                else:
                    continue  # a hair style nobody here wears
                if count:
                    draws.append(Draw(c, level, k, row, int(first), int(count)))
    return order, draws


class Blinks:
    """Eyelid closure per agent (0 open, 1 shut): spontaneous blinks and blinks with gaze shifts.

    Spontaneous blinks come at intervals of 1 s plus an exponential with mean
    2.4 s (about 17 a minute: adults at rest blink 15–20 times a minute),
    drawn from the agent's id and its blink count, so they do not depend on
    the frame rate. A gaze shift (the eyes' direction in the world turning
    more than 12° within 80 ms, 150°/s) starts a blink unless one ran in the
    last 0.6 s: large gaze shifts come with a blink (Evinger et al. 1994).
    One blink closes in 70 ms, stays shut 40 ms and opens in 140 ms.

    The renderer reads the simulation; this is the renderer's own state,
    advanced by the snapshots' times (a time going backwards starts over).
    """

    CLOSE, SHUT, OPEN = 0.07, 0.04, 0.14
    SHIFT_DEG, WINDOW = 12.0, 0.08  # a gaze shift: the eyes turn more than 12° within 80 ms (150°/s)

    def __init__(self) -> None:
        self._ids = np.zeros(0, np.int64)  # sorted ids seen so far; the arrays below follow them
        self._next = np.zeros(0)
        self._count = np.zeros(0, np.int64)
        self._start = np.zeros(0)
        self._ref_t = np.zeros(0)
        self._ref_dir = np.zeros((0, 3))
        self._t = -math.inf

    @staticmethod
    def _interval(ids: np.ndarray, k: np.ndarray) -> np.ndarray:
        u = _hash01(np.asarray(ids, np.int64) * 4099 + np.asarray(k, np.int64), 7)
        return 1.0 + -np.log1p(-u) * 2.4

    def closure(self, age: np.ndarray) -> np.ndarray:
        """Lid closure ``age`` seconds into a blink (0 before it starts and after it ends)."""
        age = np.asarray(age, np.float64)
        closing = age / self.CLOSE
        opening = 1.0 - (age - self.CLOSE - self.SHUT) / self.OPEN
        out = np.where(age < self.CLOSE, closing, np.where(age < self.CLOSE + self.SHUT, 1.0, opening))
        return np.clip(np.where(age < 0.0, 0.0, out), 0.0, 1.0)

    def _slots(self, ids: np.ndarray, t: float, dirs: np.ndarray) -> np.ndarray:
        new = np.setdiff1d(ids, self._ids)
        if new.size:
            merged = np.concatenate([self._ids, new])
            order = np.argsort(merged, kind="stable")
            first = t + 0.8 * self._interval(new, np.zeros(len(new), np.int64))
            pos = np.searchsorted(new, ids[np.isin(ids, new)])
            new_dirs = np.zeros((len(new), 3))
            new_dirs[pos] = dirs[np.isin(ids, new)]
            self._ids = merged[order]
            self._next = np.concatenate([self._next, first])[order]
            self._count = np.concatenate([self._count, np.zeros(len(new), np.int64)])[order]
            self._start = np.concatenate([self._start, np.full(len(new), -np.inf)])[order]
            self._ref_t = np.concatenate([self._ref_t, np.full(len(new), t)])[order]
            self._ref_dir = np.concatenate([self._ref_dir, new_dirs])[order]
        return np.searchsorted(self._ids, ids)

    def update(self, ids: np.ndarray, t: float, eye_dirs: np.ndarray) -> np.ndarray:
        """Closure ``(N,)`` at time ``t`` of agents ``ids`` whose eyes look along ``eye_dirs (N, 3)``."""
        if t < self._t:
            self.__init__()  # type: ignore[misc]
        self._t = t
        ids = np.asarray(ids, np.int64)
        if ids.size == 0:
            return np.zeros(0)
        dirs = np.asarray(eye_dirs, np.float64)
        k = self._slots(ids, t, dirs)
        # Gaze shifts: against the direction held at most WINDOW ago.
        cos = np.clip(np.sum(self._ref_dir[k] * dirs, axis=1), -1.0, 1.0)
        fresh = t - self._ref_t[k] <= self.WINDOW
        shift = fresh & (np.degrees(np.arccos(cos)) > self.SHIFT_DEG)
        start = self._start[k]
        self._start[k] = np.where(shift & (t - start > 0.6), t, start)
        renew = shift | ~fresh
        self._ref_t[k] = np.where(renew, t, self._ref_t[k])
        self._ref_dir[k] = np.where(renew[:, None], dirs, self._ref_dir[k])
        # Spontaneous blinks: every one whose time has come (at most a few per frame).
        due = t >= self._next[k]
        while due.any():
            kk = k[due]
            self._start[kk] = self._next[kk]
            self._count[kk] += 1
            self._next[kk] += self._interval(self._ids[kk], self._count[kk])
            due = t >= self._next[k]
        return self.closure(t - self._start[k])


def eye_directions(world: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Mean world direction ``(N, 3)`` of both eyes' +Z axes of agents ``rows``."""
    le, re = JOINTS.index("LEye"), JOINTS.index("REye")
    d = world[rows][:, [le, re]][:, :, :3, 2].astype(np.float64).sum(axis=1)
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
