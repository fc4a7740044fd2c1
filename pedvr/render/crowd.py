"""The CPU side of drawing the crowd: looks, skinning matrices, levels of detail, blinks (no GL).

Per frame the renderer needs, for every drawn agent, its skinning matrices
(:func:`skin_rows`, a numba kernel writing straight into the texture's
layout), its looks (:func:`agent_looks`: colours and garments, drawn once from
the agent's stable id and its body dims) with the blink of the moment
(:class:`Blinks`), and which character and level of detail draws it
(:func:`draw_groups`). Everything here is deterministic in the agent ids and
the snapshot's time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from pedvr.body import JOINTS, rest_positions
from pedvr.body import skeleton as sk

N_JOINTS = len(JOINTS)
SKIN_TEXELS = 3 * N_JOINTS  # rows of each bone's 3×4 skinning matrix
LOOK_TEXELS = 8
LOD_DISTANCES = (6.0, 15.0)  # m: level 0 nearer than 6 m, level 1 nearer than 15 m, level 2 beyond


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


def lod_levels(pos: np.ndarray, viewer: np.ndarray | None, levels: int = 3) -> np.ndarray:
    """Level of detail ``(N,) int64`` by ground distance from ``viewer`` (2D); all 0 without a viewer."""
    n = len(pos)
    if viewer is None:
        return np.zeros(n, np.int64)
    d = np.hypot(pos[:, 0] - viewer[0], pos[:, 1] - viewer[1])
    lod = np.searchsorted(np.asarray(LOD_DISTANCES), d, side="right")
    return np.minimum(lod, levels - 1).astype(np.int64)


def draw_groups(character: np.ndarray, lod: np.ndarray, characters: int,
                levels: int) -> tuple[np.ndarray, list[tuple[int, int, int, int]]]:
    """Instance order and the draws: ``order (N,)`` agent rows sorted by (character, level), and
    ``(character, level, first, count)`` for each non-empty group (one draw call each)."""
    key = np.asarray(character, np.int64) * levels + np.asarray(lod, np.int64)
    order = np.argsort(key, kind="stable")
    counts = np.bincount(key, minlength=characters * levels)
    groups, first = [], 0
    for g, c in enumerate(counts):
        if c:
            groups.append((g // levels, g % levels, first, int(c)))
        first += int(c)
    return order.astype(np.int32), groups


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
