"""What a pedestrian carries: a box held in front of the chest, or a perambulator pushed ahead.

Huang & Terzopoulos §4.6 ("carrying a box ... pushing a perambulator": no free hand,
they push a door with the body or wait for help) name the two; a scene profile says
which (``carrying = "none" | "box" | "perambulator"``, :mod:`pedvr.scene.config`).
The paper gives no geometry; pedvr's choice, in the body's frame (forward along the
2D heading, left along ``(sin θ, -cos θ)`` as in :mod:`pedvr.body`, up +Y; the box's
lengths times the body's scale ``height / 1.75`` (it is held where the chest is), the
pram's in metres whoever pushes it (a pram has its own size: :func:`object_scale`):

* **box**: 0.40 m wide, 0.30 m deep, 0.30 m tall, its centre :data:`BOX_AHEAD` ahead
  of the root at :data:`BOX_HEIGHT`; the hands hold its two sides at mid height
  (arm IK, both arms, :func:`hand_targets`).
* **perambulator**: a handle bar :data:`PRAM_HANDLE_WIDTH` wide, :data:`PRAM_HANDLE_AHEAD`
  ahead at :data:`PRAM_HANDLE_HEIGHT`; the hands hold it at its ends. The pram itself
  (basket and four wheels, :data:`PRAM_BASKET` in the same frame) lies ahead of the
  handle; its footprint is not the body's (the crowd layer's, see the scene docs).

Both arms reach for these points every step (the reach choreographer, which replaces
the walk's arm swing on the arms it moves), so the hands follow the body; the pose graph
solves the reaching arms again after the legs' IK has set the pelvis height, so where the
knees bend (starting to walk, slowing down) the hands stay on their points
(:func:`pedvr.body.graph._arms_again`). The box is drawn between the hands
(:func:`object_frame`), the pram's handle stays at its height; a hand the
behaviour layer takes explicitly (``FullBody.reach_for``) leaves the carry for as long
as it is taken (§4.6's carrier who, after waiting alone, frees a hand to pull a door:
:data:`pedvr.etiquette.system.CARRIER_PATIENCE`), and returns to it when released.

Everything here is pure numpy: the renderer draws the box and the pram from the same
frame (:func:`carry_frame`), so the hands are on what is drawn.
"""

from __future__ import annotations

import numpy as np

NONE, BOX, PERAMBULATOR = 0, 1, 2
KINDS = {"none": NONE, "box": BOX, "perambulator": PERAMBULATOR}

BOX_SIZE = (0.30, 0.30, 0.40)  # m: depth (forward), height, width (across)
BOX_AHEAD = 0.34  # m: box centre ahead of the root
BOX_HEIGHT = 1.08  # m: box centre above the floor

PRAM_HANDLE_AHEAD = 0.36  # m: the handle bar ahead of the root (elbows bent: a pusher walks close)
PRAM_HANDLE_HEIGHT = 1.0  # m
PRAM_HANDLE_WIDTH = 0.46  # m: the hands at its ends, about shoulder width
# The pram's basket: forward from, forward to, bottom, top, half width (m, body frame).
PRAM_BASKET = (0.50, 1.12, 0.38, 0.80, 0.27)
PRAM_WHEEL_RADIUS = 0.13  # m
PRAM_AXLES = (PRAM_BASKET[0] + 0.08, PRAM_BASKET[1] - 0.08)  # m: rear and front axle ahead of the root
PRAM_FRONT = PRAM_AXLES[1] + PRAM_WHEEL_RADIUS  # m: the pram's frontmost point (a front wheel's rim)
# The outline of pusher and pram in the body frame (forward, across; m): the pusher's back and
# shoulders, the handle's ends, the basket's corners and the wheels' extremes. The crowd layer's
# footprint for a pram is the ellipse round these (pedvr.crowd.footprint.enclosing_ellipse).
PRAM_HULL = np.array(
    [[-0.20, 0.0], [-0.12, 0.20], [-0.12, -0.20], [0.0, 0.25], [0.0, -0.25],
     [PRAM_HANDLE_AHEAD, PRAM_HANDLE_WIDTH / 2 + 0.02], [PRAM_HANDLE_AHEAD, -PRAM_HANDLE_WIDTH / 2 - 0.02]]
    + [[x, y] for x in (PRAM_BASKET[0], PRAM_BASKET[1]) for y in (PRAM_BASKET[4], -PRAM_BASKET[4])]
    + [[x, y] for x in (PRAM_AXLES[0] - PRAM_WHEEL_RADIUS, PRAM_FRONT)
       for y in (PRAM_BASKET[4], -PRAM_BASKET[4])])


def kind_codes(names: list[str] | tuple[str, ...] | np.ndarray) -> np.ndarray:
    """``(N,) int8`` codes (:data:`NONE`, :data:`BOX`, :data:`PERAMBULATOR`) of profile ``carrying`` names."""
    return np.asarray([KINDS[str(s)] for s in names], np.int8).reshape(-1)


def carry_frame(root: np.ndarray, heading: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                                  np.ndarray]:
    """The body frame in 3D world coordinates: ``origin (N, 3)`` (the root on the floor),
    ``forward (N, 3)`` and ``left (N, 3)`` unit vectors; lengths in this frame are to be
    multiplied by ``scale (N,)`` by the caller."""
    root = np.asarray(root, np.float64).reshape(-1, 2)
    h = np.asarray(heading, np.float64).reshape(-1)
    n = root.shape[0]
    origin = np.zeros((n, 3))
    origin[:, 0], origin[:, 2] = root[:, 0], root[:, 1]
    forward = np.zeros((n, 3))
    forward[:, 0], forward[:, 2] = np.cos(h), np.sin(h)
    left = np.zeros((n, 3))
    left[:, 0], left[:, 2] = np.sin(h), -np.cos(h)
    return origin, forward, left


def object_scale(kind: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(N,)`` the factor the carried object's lengths are multiplied by: the body's scale
    for a box, 1 for a perambulator."""
    pram = np.asarray(kind).reshape(-1) == PERAMBULATOR
    return np.where(pram, 1.0, np.asarray(scale, np.float64).reshape(-1))


def object_yaw(kind: np.ndarray, heading: np.ndarray, shoulder_turn: np.ndarray) -> np.ndarray:
    """``(N,)`` the 2D facing (rad) of what is carried: a box turns with the chest (a carrier
    squeezing past someone turns the box with it: ``BodyState.shoulder_turn`` is a turn about
    the 3D vertical +Y, so a 2D turn of ``-shoulder_turn``, :mod:`pedvr.body`'s convention), a
    pram follows the heading (its pusher never turns its shoulders: pusher and pram are one
    rigid footprint)."""
    box = np.asarray(kind).reshape(-1) == BOX
    return np.asarray(heading, np.float64) - np.where(box, np.asarray(shoulder_turn, np.float64), 0.0)


FRAME_COLUMNS = 5  # object_frame's x, y, z, yaw, tilt


def object_frame(kind: np.ndarray, root: np.ndarray, yaw: np.ndarray, scale: np.ndarray,
                 hands: np.ndarray, taken: np.ndarray) -> np.ndarray:
    """``(N, 5)`` where a carried thing is drawn: ``x, y, z`` (3D world, m), its 2D ``yaw`` and
    its ``tilt`` (rad, about its forward axis, its left side up; a box held in both hands only).
    A box's centre lies between the two hands (``hands (N, 2, 3)``, the posed hand joints), so it
    is drawn where it is held even where the pose graph moved the arms after the reach (the legs'
    IK lowering the pelvis, the chest turning); where a hand is ``taken (N, 2)`` by the behaviour,
    it is where the hands would hold it. A pram's reference point is the root on the floor (it
    is the crowd layer's footprint, placed by the root)."""
    kind = np.asarray(kind).reshape(-1)
    sc = object_scale(kind, scale)
    origin, forward, _ = carry_frame(root, yaw, sc)
    out = np.zeros((kind.shape[0], FRAME_COLUMNS))
    box = kind == BOX
    centre = origin + forward * (BOX_AHEAD * sc)[:, None]
    centre[:, 1] = BOX_HEIGHT * sc
    both = box & ~np.asarray(taken, np.bool_).any(axis=1)
    hands = np.asarray(hands, np.float64)
    centre = np.where(both[:, None], hands.mean(axis=1), centre)
    out[:, :3] = np.where(box[:, None], centre, origin)
    out[:, 3] = yaw
    # ... and tilted as the hands hold it: the chest's turn rotates the arms about a spine that
    # leans while walking (graph.turn_shoulders), so at a 38° turn one hand rides 2 cm above the
    # other; a level box was drawn 1 cm off both.
    across = hands[:, 0] - hands[:, 1]
    sep = np.linalg.norm(across, axis=1)
    tilt = np.arcsin(np.clip(across[:, 1] / np.where(sep > 1e-9, sep, 1.0), -1.0, 1.0))
    out[:, 4] = np.where(both & (sep > 1e-9), tilt, 0.0)
    return out


def hand_targets(kind: np.ndarray, root: np.ndarray, heading: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(N, 2, 3)`` world points for the left (0) and right (1) hand: the box's sides or the
    handle's ends (see the module docstring), the object facing ``heading`` (its
    :func:`object_yaw`); rows that carry nothing get the box's points (callers use only the
    carrying rows)."""
    kind = np.asarray(kind).reshape(-1)
    sc = object_scale(kind, scale)[:, None]
    origin, forward, left = carry_frame(root, heading, scale)
    pram = (kind == PERAMBULATOR)[:, None]
    ahead = np.where(pram, PRAM_HANDLE_AHEAD, BOX_AHEAD) * sc
    up = np.where(pram, PRAM_HANDLE_HEIGHT, BOX_HEIGHT) * sc
    half = np.where(pram, PRAM_HANDLE_WIDTH / 2, BOX_SIZE[2] / 2) * sc
    centre = origin + forward * ahead
    centre[:, 1] = up[:, 0]
    out = np.empty((kind.shape[0], 2, 3))
    out[:, 0] = centre + left * half
    out[:, 1] = centre - left * half
    return out
