"""Procedural skinned characters on the body layer's 26-joint skeleton (no GL, no assets).

One mesh topology serves every procedural agent: a smooth body made of
implicit primitives around the bones (torso, limbs, hands with a thumb and a
fingers block, shoes, neck, head with brows, nose, lips, ears and eye
sockets), polygonised once (:mod:`pedvr.render.implicit`), decimated into
levels of detail, and skinned to the skeleton. Body types are continuous:
the vertices carry two shape offsets (sex and build), found by projecting
the template's surface onto the female and slender/heavy variants of the same
field, so ``pos = base + sex · d_sex + (build − ½) · d_build`` follows the
body layer's dims (:func:`pedvr.body.skeleton.draw_dims`); height is the
renderer's uniform scale. Hair styles and the skirt are separate closed
pieces of the same vertex buffer, each tagged with a ``variant``: the shader
keeps the ones an agent wears and collapses the others.

Faces carry gaze (issue 16): eyeballs are spheres skinned rigidly to
``LEye``/``REye`` (iris and pupil drawn in the fragment shader from the
vertex's direction in the eye's frame, so they stay sharp at any mesh
resolution); each eye has an upper and a lower lid, thin shells about the
eye's centre skinned to ``Head``, which the vertex shader turns about the
eye's horizontal axis for blinks and to follow the eye's pitch.

Skin weights come from distances to the flesh of each bone (each primitive
belongs to a bone): ``w_b ∝ exp(−(d_b − d_min)/σ)``, smoothed twice over the
mesh, at most four bones per vertex, summing to one. Clothing is decided per
fragment, not per vertex, so its edges are sharp at every level of detail,
and every edge is a smooth curve (issue 25 item 18: the hems were jagged,
following the triangles where thresholded skin weights crossed ½). The body
is cut along two seams, the zero sets of smooth fields (:class:`_Seams`: the
surface equidistant from the arms' flesh and the rest, through the armpits
and over the shoulders; likewise for the legs, below the lowest shirt hem),
so each triangle is wholly ARM, LEG or TRUNK (:func:`cut_along`). Each body
vertex carries its fraction along its limb (linear in the bind pose) and its
bind-pose position, and the fragment shader compares them with the agent's
sleeve and trouser lengths (a plane across the limb), its shirt hem (a plane
round the trunk) and the neckline (a smooth curve of the bind-pose position);
lips and brows are drawn from the bind-pose position too.

Generation takes about a second and is cached in the user's cache directory
(``$XDG_CACHE_HOME/pedvr`` or ``~/.cache/pedvr``), keyed by this module's and
:mod:`pedvr.render.implicit`'s source; :func:`procedural_character` also
keeps it in memory for the process.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from pedvr.body import JOINTS, rest_positions
from pedvr.body import skeleton as sk
from pedvr.render import implicit as im
from pedvr.render.implicit import ELLIPSOID, HALF_SPACE, INTERSECT, ROUND_BOX, ROUND_CONE, SUBTRACT, Prim

# Regions: what a vertex is made of, for the fragment shader's materials.
SKIN, TRUNK, ARM, LEG, FOOT, EYE, LID_UPPER, LID_LOWER, HAIR, SKIRT, LIPS, BROW = range(12)
BODY_REGIONS = (TRUNK, ARM, LEG)  # the body's one surface, cut along its seams
ALWAYS = -1  # variant of the pieces every agent wears
SKIRT_VARIANT = 10
HAIR_STYLES = ("short", "long", "bun", "buzz", "bob")

VERTEX_DTYPE = np.dtype([
    ("pos", "<f4", 3), ("normal", "<f4", 3), ("dsex", "<f4", 3), ("dbuild", "<f4", 3),
    ("bones", "u1", 4), ("weights", "<f4", 4), ("region", "<i4"), ("t", "<f4"),
    ("local", "<f4", 3), ("ao", "<f4"), ("uv", "<f4", 2), ("variant", "<i4"),
])
VERTEX_FORMAT = "3f 3f 3f 3f 4u1 4f 1i 1f 3f 1f 2f 1i"
VERTEX_ATTRIBUTES = ("in_pos", "in_normal", "in_dsex", "in_dbuild", "in_bones", "in_weights", "in_region",
                     "in_t", "in_local", "in_ao", "in_uv", "in_variant")

EYE_RADIUS = 0.0122  # m (an adult eyeball is about 24 mm across)
LID_INNER, LID_OUTER = 0.0127, 0.0139  # m: the lids' shell, just off the eyeball
LID_OPEN_UPPER = math.radians(24.0)  # rad above the eye's axis: the open upper lid's margin
LID_OPEN_LOWER = math.radians(-21.0)  # rad: the lower lid's margin
SIGMA = 0.012  # m: how far skin weights blend across the flesh of neighbouring bones
LOD_TRIANGLES = {  # per piece and level of detail (the body's before its seams are cut, which adds
    # about 500, 300 and 120 triangles to the first three: as many as the uncut 11000, 2800 and 700
    # had). The levels' largest deviations from level 0 (CharacterMesh.lod_error) come out near 3, 6,
    # 11 and 19 mm, about doubling from level to level, so that each level serves from twice the
    # distance of the one before (issue 27: pedvr/render/crowd.py lod_levels). Long hair needs more
    # triangles than the other styles for the same deviation (with fewer the decimator folds its tail
    # away: 28 mm); the skirt keeps all its triangles at level 1 (fewer cost it 5 mm). Hair is a
    # shell millimetres over the scalp: decimated, it sinks into it and the scalp shows through in
    # patches wider than its deviation says (at 450 triangles, level 1, plainly along the hairline 2 m
    # away in a headset), so it keeps all its triangles at level 1 and 600 at level 2.
    "body": (10500, 5000, 2500, 900, 575), "hair": (1000, 1000, 600, 320, 140),
    "hair_long": (1000, 1000, 600, 320, 200), "skirt": (600, 600, 200, 60, 60), "eye": (200, 120, 80, 32, 32),
    "lid": (140, 80, 50, 20, 20),
}
LEVELS = len(LOD_TRIANGLES["body"])
# Each level's largest deviation from level 0 (m): lod_deviation of the procedural character at a
# 1.5 mm spacing, written here because measuring takes most of a minute and the mesh is generated
# on a cold start (issue 27 goal 2); tests/render/test_characters.py measures it again.
PROCEDURAL_LOD_ERROR = (0.0, 0.0030, 0.0061, 0.0106, 0.0187)
MESH_VERSION = 3
LEG_SEAM_Y = 0.9  # m, bind pose: the legs begin below this height (under the lowest shirt hem, 0.95 m)
SEAM_SNAP = 0.08  # a seam crossing an edge this close to a vertex goes through the vertex (no slivers)
ARM_BONES = tuple(f"{s}{j}" for s in "LR" for j in ("Shoulder", "Elbow", "Wrist", "Hand"))
LEG_BONES = tuple(f"{s}{j}" for s in "LR" for j in ("Hip", "Knee", "Ankle", "Toe"))

_J = {n: i for i, n in enumerate(JOINTS)}


@dataclass(frozen=True)
class MeshLOD:
    """One level of detail: vertices (:data:`VERTEX_DTYPE`) and triangles ``(T, 3) uint32``."""

    vertices: np.ndarray
    triangles: np.ndarray


@dataclass(frozen=True)
class CharacterMesh:
    """A drawable character: levels of detail from near to far, and its bind-pose joints.

    ``rest`` ``(26, 3)`` are the joint positions the vertices are bound to at
    the 1.75 m reference height; None for the procedural body, whose joints
    follow each agent's dims (:func:`pedvr.body.rest_positions`).
    ``texture`` is an RGBA ``uint8`` base-colour image (avatars), or None.
    ``lod_error`` is each level's largest deviation (m) from level 0's surface
    (:func:`lod_deviation`; 0 for level 0), which picks the distance each level
    is drawn from; empty when not measured (the renderer measures it then).
    """

    name: str
    lods: tuple[MeshLOD, ...]
    rest: np.ndarray | None = None
    texture: np.ndarray | None = None
    lod_error: tuple[float, ...] = ()

    @property
    def vertex_counts(self) -> tuple[int, ...]:
        return tuple(len(lod.vertices) for lod in self.lods)


# -- the shapes -----------------------------------------------------------------------------------


def _rest(sex: float, build: float) -> np.ndarray:
    d = np.array([[sk.REFERENCE_HEIGHT, sex, build, 1.0]])
    return rest_positions(d)[0]


def _v3(a: Sequence[float] | np.ndarray) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in a)
    return x, y, z


def body_prims(sex: float, build: float) -> list[Prim]:
    """The body's primitives for ``sex`` (0 male, 1 female) and ``build`` (0 slender .. 1 heavy).

    Sized for the 1.75 m reference adult around the body layer's bind-pose
    joints (hips 0.93 m, eyes 1.64 m, head top 1.75 m); flesh radii grow with
    build (×0.84 .. ×1.16), women have narrower shoulders (the skeleton's),
    a narrower waist, wider hips and breasts.
    """
    r = _rest(sex, build)
    g = 0.84 + 0.32 * build  # girth
    f = sex
    P: list[Prim] = []

    def add(kind: int, a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray, *, bone: str,
            region: int, ra: float = 0.0, rb: float = 0.0, k: float = 0.0, op: int = 0,
            squash: float = 1.0) -> None:
        P.append(Prim(kind, _v3(a), _v3(b), ra, rb, k, op, _J[bone], region, squash))

    # Trunk: pelvis, abdomen, chest, shoulder line, buttocks.
    hip_w = abs(r[_J["LHip"], 0]) / 0.09
    sh_w = abs(r[_J["LShoulder"], 0]) / 0.225
    add(ELLIPSOID, (0, 0.965, -0.01), (0.158 * hip_w * g ** 0.5, 0.115, 0.105 * g), bone="Pelvis",
        region=TRUNK)
    add(ELLIPSOID, (0, 1.14, -0.002), ((0.138 - 0.018 * f) * g, 0.14, (0.092 + 0.012 * build) * g),
        bone="Spine1", region=TRUNK, k=0.06)
    add(ELLIPSOID, (0, 1.315, -0.008), ((0.158 - 0.012 * f) * sh_w * g ** 0.5, 0.14, 0.102 * g),
        bone="Spine2", region=TRUNK, k=0.06)
    add(ROUND_CONE, (0.175 * sh_w, 1.405, -0.02), (-0.175 * sh_w, 1.405, -0.02), bone="Spine3",
        region=TRUNK, ra=0.058 * g, rb=0.058 * g, k=0.05)
    for s in (1.0, -1.0):
        side = "L" if s > 0 else "R"
        add(ELLIPSOID, (0.062 * s * hip_w, 0.9, -0.05), (0.075 * g, 0.085, 0.06 * g), bone="Pelvis",
            region=TRUNK, k=0.04)
        if f > 0.5:
            add(ELLIPSOID, (0.054 * s, 1.285, 0.066), (0.058, 0.054, 0.05), bone="Spine2", region=TRUNK,
                k=0.025)
        # Arm: deltoid, upper arm, forearm.
        sh, el, wr, hd = (r[_J[f"{side}{n}"]] for n in ("Shoulder", "Elbow", "Wrist", "Hand"))
        tip = r[sk.IDX[f"{side}HandTip"]]
        add(ELLIPSOID, sh + (0.0, -0.015, 0.0), (0.058 * g, 0.065 * g, 0.058 * g), bone=f"{side}Shoulder",
            region=ARM, k=0.03)
        add(ROUND_CONE, sh, el, bone=f"{side}Shoulder", region=ARM, ra=0.047 * g, rb=0.036 * g, k=0.02)
        add(ROUND_CONE, el, wr + (0, 0.01, 0), bone=f"{side}Elbow", region=ARM, ra=0.038 * g,
            rb=0.026 * g ** 0.5, k=0.015)
        # Hand: palm (thin along x, the palm faces the thigh), fingers block, thumb toward the front.
        hs = 1.0 - 0.07 * f
        palm_c = 0.5 * (wr + hd) + (0.0, -0.005, 0.004)
        add(ROUND_BOX, palm_c, (0.0125 * hs, 0.043 * hs, 0.036 * hs), bone=f"{side}Wrist", region=SKIN,
            ra=0.011, k=0.012)
        add(ROUND_BOX, 0.5 * (hd + tip) + (-0.003 * s, 0.0, 0.004), (0.0105 * hs, 0.047 * hs, 0.034 * hs),
            bone=f"{side}Hand", region=SKIN, ra=0.0095, k=0.008)
        add(ROUND_CONE, wr + (-0.004 * s, -0.035, 0.03), wr + (-0.008 * s, -0.085 * hs, 0.05 * hs),
            bone=f"{side}Wrist", region=SKIN, ra=0.012 * hs, rb=0.0085 * hs, k=0.01)
        # Leg: thigh, shin, calf; shoe.
        hp, kn, an = (r[_J[f"{side}{n}"]] for n in ("Hip", "Knee", "Ankle"))
        add(ROUND_CONE, hp + (0.004 * s, 0.02, -0.005), kn, bone=f"{side}Hip", region=LEG,
            ra=(0.084 + 0.01 * f) * g, rb=0.052 * g, k=0.04)
        add(ROUND_CONE, kn, an + (0, 0.02, 0), bone=f"{side}Knee", region=LEG, ra=0.05 * g, rb=0.034,
            k=0.02)
        add(ELLIPSOID, kn + (0, -0.15, -0.022), (0.047 * g, 0.11, 0.05 * g), bone=f"{side}Knee",
            region=LEG, k=0.03)
        heel, toe = r[sk.IDX[f"{side}Heel"]], r[sk.IDX[f"{side}ToeTip"]]
        add(ELLIPSOID, an + (0, -0.01, -0.005), (0.042, 0.048, 0.048), bone=f"{side}Ankle", region=FOOT,
            k=0.02)
        add(ROUND_CONE, heel + (0, 0.04, 0.01), toe + (0, 0.033, -0.052), bone=f"{side}Ankle",
            region=FOOT, ra=0.042, rb=0.04, k=0.02, squash=0.85)
        add(ROUND_CONE, toe + (0, 0.032, -0.055), toe + (0, 0.028, -0.012), bone=f"{side}Toe",
            region=FOOT, ra=0.04, rb=0.03, k=0.015, squash=0.8)
    # Neck and head: cranium, face, jaw, cheeks, ears, brows, nose, lips.
    nk, hd = r[_J["Neck"]], r[_J["Head"]]
    add(ROUND_CONE, nk + (0, -0.03, -0.002), hd + (0, 0.0, -0.004), bone="Neck", region=SKIN,
        ra=(0.062 - 0.006 * f) * g ** 0.5, rb=0.05 - 0.004 * f, k=0.035)
    y0 = hd[1]  # 1.60 m for the reference adult
    add(ELLIPSOID, (0, y0 + 0.066, -0.008), (0.076, 0.094, 0.099), bone="Head", region=SKIN, k=0.02)
    add(ELLIPSOID, (0, y0 + 0.025, 0.038), (0.067, 0.085, 0.071), bone="Head", region=SKIN, k=0.03)
    add(ELLIPSOID, (0, y0 - 0.033, 0.045), (0.052 - 0.004 * f, 0.04, 0.055), bone="Head", region=SKIN,
        k=0.03)
    for s in (1.0, -1.0):
        add(ELLIPSOID, (0.043 * s, y0 + 0.012, 0.062), (0.028, 0.026, 0.03), bone="Head", region=SKIN,
            k=0.02)
        add(ELLIPSOID, (0.077 * s, y0 + 0.037, -0.004), (0.011, 0.029, 0.018), bone="Head", region=SKIN,
            k=0.01)
        add(ROUND_CONE, (0.012 * s, y0 + 0.061, 0.098), (0.052 * s, y0 + 0.058, 0.085), bone="Head",
            region=BROW, ra=0.0062, rb=0.0045, k=0.008)
    add(ROUND_CONE, (0, y0 + 0.047, 0.099), (0, y0 + 0.008, 0.121), bone="Head", region=SKIN,
        ra=0.0085, rb=0.0125, k=0.012)
    for s in (1.0, -1.0):
        add(ELLIPSOID, (0.0125 * s, y0 + 0.008, 0.108), (0.0095, 0.008, 0.009), bone="Head", region=SKIN,
            k=0.008)
    # Lips standing 4 mm proud of the face's surface (10.6 cm in front of the head joint there), so
    # that they show: each half of each lip a cone tapering from the middle to the corner, set back
    # there with the face's curve. crowd.glsl colours the surface near these cones (UPPER_LIP_A ...).
    for s in (1.0, -1.0):
        add(ROUND_CONE, (0.0, y0 - 0.0165, 0.1045), (0.022 * s, y0 - 0.018, 0.1015), bone="Head",
            region=LIPS, ra=0.0052, rb=0.0022, k=0.006)
        add(ROUND_CONE, (0.0, y0 - 0.0285, 0.102), (0.019 * s, y0 - 0.0265, 0.0995), bone="Head",
            region=LIPS, ra=0.0064, rb=0.0024, k=0.006)
    # Eye sockets, carved: the eyeballs and lids sit in them.
    for side in "LR":
        add(ELLIPSOID, r[_J[f"{side}Eye"]] + (0, 0, 0.001), (0.0152, 0.0146, 0.0146), bone="Head",
            region=SKIN, k=0.004, op=SUBTRACT)
    # Flat soles.
    add(HALF_SPACE, (0, 0.0, 0), (0, -1.0, 0), bone="Pelvis", region=FOOT, op=INTERSECT)
    return P


def hair_prims(style: str) -> list[Prim]:
    """A hair style as a solid over the reference head (it may reach into the head: only the outside
    shows)."""
    y0 = _rest(0.0, 0.5)[_J["Head"], 1]
    head = _J["Head"]

    def e(c: tuple[float, float, float], rad: tuple[float, float, float], k: float = 0.02) -> Prim:
        return Prim(ELLIPSOID, c, rad, k=k, bone=head, region=HAIR)

    def cut(point: tuple[float, float, float], normal: tuple[float, float, float]) -> Prim:
        n = np.asarray(normal, np.float64)
        n /= np.linalg.norm(n)
        return Prim(HALF_SPACE, point, tuple(float(v) for v in n), op=INTERSECT, bone=head,  # type: ignore[arg-type]
                    region=HAIR)

    cap = e((0, y0 + 0.07, -0.012), (0.084, 0.1, 0.107))
    # The hairline: off the forehead and above the ears, down to the nape behind.
    forehead = cut((0, y0 + 0.083, 0.09), (0, -0.55, 1.0))
    temples = cut((0, y0 + 0.045, 0.03), (0, -1.0, 0.9))
    if style == "buzz":
        return [e((0, y0 + 0.068, -0.01), (0.0795, 0.0975, 0.1025)), forehead, temples]
    if style == "short":
        return [cap, e((0, y0 + 0.115, 0.015), (0.07, 0.06, 0.085)), forehead, temples]
    if style == "bun":
        return [cap, e((0, y0 + 0.1, -0.105), (0.042, 0.042, 0.04), k=0.02), forehead, temples]
    if style == "bob":
        return [cap, e((0, y0 + 0.03, -0.02), (0.092, 0.095, 0.1), k=0.03),
                cut((0, y0 + 0.08, 0.08), (0, -0.35, 1.0)), cut((0, y0 - 0.045, 0), (0, -1.0, 0)),
                cut((0, y0 + 0.03, 0.045), (0, -0.6, 1.0))]
    if style == "long":
        return [cap, e((0, y0 - 0.04, -0.045), (0.088, 0.17, 0.062), k=0.03),
                cut((0, y0 + 0.08, 0.08), (0, -0.35, 1.0)), cut((0, y0 - 0.2, 0), (0, -1.0, 0)),
                cut((0, y0 + 0.03, 0.03), (0, -0.6, 1.0))]
    raise ValueError(f"hair style {style!r}: expected one of {', '.join(HAIR_STYLES)}")


def skirt_prims() -> list[Prim]:
    """A skirt from the waist to just above the knee (elliptical, wider than the hips)."""
    pelvis = _J["Pelvis"]
    return [Prim(ROUND_CONE, (0, 1.0, -0.01), (0, 0.52, -0.01), ra=0.165, rb=0.25, bone=pelvis,
                 region=SKIRT, squash=0.72),
            Prim(HALF_SPACE, (0, 0.55, 0), (0, -1.0, 0), op=INTERSECT, bone=pelvis, region=SKIRT),
            Prim(HALF_SPACE, (0, 1.01, 0), (0, 1.0, 0), op=INTERSECT, bone=pelvis, region=SKIRT)]


def eye_prims(side: str) -> list[Prim]:
    c = _rest(0.0, 0.5)[_J[f"{side}Eye"]]
    return [Prim(ELLIPSOID, tuple(c), (EYE_RADIUS,) * 3, bone=_J[f"{side}Eye"], region=EYE)]  # type: ignore[arg-type]


def lid_prims(side: str, upper: bool) -> list[Prim]:
    """A lid: the shell between LID_INNER and LID_OUTER about the eye's centre, from its margin
    (LID_OPEN_UPPER above the axis, or LID_OPEN_LOWER below) 100° round over the eye, cut to the
    eye's width."""
    c = _rest(0.0, 0.5)[_J[f"{side}Eye"]]
    head = _J["Head"]
    region = LID_UPPER if upper else LID_LOWER
    m = LID_OPEN_UPPER if upper else LID_OPEN_LOWER
    far = m + math.radians(100.0) if upper else m - math.radians(100.0)
    sgn = 1.0 if upper else -1.0
    # Half-spaces through the eye's x axis: keep angles beyond the margin (toward the lid) and before `far`.
    n_margin = (0.0, -sgn * math.cos(m), sgn * math.sin(m))
    n_far = (0.0, sgn * math.cos(far), -sgn * math.sin(far))
    ct = tuple(float(v) for v in c)
    return [
        Prim(ELLIPSOID, ct, (LID_OUTER,) * 3, bone=head, region=region),  # type: ignore[arg-type]
        Prim(ELLIPSOID, ct, (LID_INNER,) * 3, op=SUBTRACT, bone=head, region=region),  # type: ignore[arg-type]
        Prim(HALF_SPACE, ct, n_margin, op=INTERSECT, bone=head, region=region),  # type: ignore[arg-type]
        Prim(HALF_SPACE, ct, n_far, op=INTERSECT, bone=head, region=region),  # type: ignore[arg-type]
        Prim(HALF_SPACE, (c[0] + 0.0135, 0, 0), (1.0, 0, 0), op=INTERSECT, bone=head, region=region),
        Prim(HALF_SPACE, (c[0] - 0.0135, 0, 0), (-1.0, 0, 0), op=INTERSECT, bone=head, region=region),
    ]


# -- grids -----------------------------------------------------------------------------------------


def _body_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fine (3.5–5 mm) across the face and hands, 9–10 mm elsewhere."""
    xs = im.axis([(-0.34, -0.29, 0.01), (-0.29, -0.165, 0.0045), (-0.165, -0.1, 0.009), (-0.1, 0.1, 0.0035),
                  (0.1, 0.165, 0.009), (0.165, 0.29, 0.0045), (0.29, 0.34, 0.01)])
    ys = im.axis([(-0.01, 0.13, 0.005), (0.13, 0.64, 0.01), (0.64, 0.94, 0.005), (0.94, 1.52, 0.01),
                  (1.52, 1.8, 0.0035)])
    zs = im.axis([(-0.2, 0.02, 0.009), (0.02, 0.14, 0.0035), (0.14, 0.25, 0.008)])
    return xs, ys, zs


def _box_grid(lo: np.ndarray, hi: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return tuple(im.axis([(float(a), float(b), step)]) for a, b in zip(lo, hi, strict=True))  # type: ignore[return-value]


# -- building -------------------------------------------------------------------------------------


@dataclass
class _Piece:
    name: str
    table: np.ndarray
    prims: list[Prim]
    verts: np.ndarray
    tris: np.ndarray
    variant: int
    lod_tris: tuple[int, ...]


def closed_manifold(tris: np.ndarray) -> bool:
    """Whether triangles ``(T, 3)`` form closed, consistently oriented surfaces (each directed edge
    once, and its reverse once)."""
    t = np.asarray(tris, np.int64)
    d = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    key = d[:, 0] * (int(t.max()) + 1) + d[:, 1]
    rev = d[:, 1] * (int(t.max()) + 1) + d[:, 0]
    return len(np.unique(key)) == len(key) and bool(np.isin(rev, key).all())


def _decimate(verts: np.ndarray, tris: np.ndarray, target: int, *,
              closed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Quadric decimation to about ``target`` triangles that stays a closed manifold (``closed``):
    the decimator now and then pinches an edge; then a little less aggressive or a few more
    triangles. With ``closed=False`` (meshes with open seams) the first result is taken."""
    if len(tris) <= target:
        return verts, tris
    import fast_simplification

    tries = [(f, agg) for f in (1.0, 1.04, 1.09, 1.15) for agg in (5.0, 4.0, 6.0, 3.0)]
    for f, agg in tries:
        v, t = fast_simplification.simplify(verts.astype(np.float64), tris.astype(np.int32),
                                            target_count=int(target * f), agg=agg)
        t = np.asarray(t, np.int64)
        if not closed or closed_manifold(t):
            break
    else:
        raise RuntimeError(f"decimating {len(tris)} triangles to {target} keeps breaking the surface")
    used = np.unique(t)
    remap = np.full(len(v), -1, np.int64)
    remap[used] = np.arange(len(used))
    return np.asarray(v)[used], remap[t]


def _adjacency(n: int, tris: np.ndarray) -> object:
    from scipy.sparse import coo_matrix

    i = np.concatenate([tris[:, 0], tris[:, 1], tris[:, 2], tris[:, 1], tris[:, 2], tris[:, 0]])
    j = np.concatenate([tris[:, 1], tris[:, 2], tris[:, 0], tris[:, 0], tris[:, 1], tris[:, 2]])
    a = coo_matrix((np.ones(len(i)), (i, j)), shape=(n, n)).tocsr()
    a.data[:] = 1.0
    return a


def _top4(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    idx = np.argsort(-w, axis=1, kind="stable")[:, :4]
    top = np.take_along_axis(w, idx, axis=1)
    top = np.where(top > 1e-3, top, 0.0)
    top /= top.sum(axis=1, keepdims=True)
    idx = np.where(top > 0, idx, 0)
    return idx.astype(np.uint8), top.astype(np.float32)


def _skin_weights(piece: _Piece, verts: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bones ``(V, 4) uint8`` and weights ``(V, 4) float32`` (sum 1) of a piece's vertices."""
    n = len(verts)
    region = piece.prims[0].region
    if piece.name.startswith(("eye", "lid", "hair")):
        w = np.zeros((n, len(JOINTS)))
        w[:, piece.prims[0].bone] = 1.0
        return _top4(w)
    if region == SKIRT:
        # Swings with the thighs toward the hem, on the side each vertex is on.
        w = np.zeros((n, len(JOINTS)))
        down = np.clip((1.0 - verts[:, 1]) / 0.45, 0.0, 1.0) * 0.55
        side = np.clip(0.5 + verts[:, 0] / 0.16, 0.0, 1.0)
        w[:, _J["Pelvis"]] = 1.0 - down
        w[:, _J["LHip"]] = down * side
        w[:, _J["RHip"]] = down * (1.0 - side)
        return _top4(w)
    dist = np.empty((n, len(piece.prims)))
    im.prim_distances(np.ascontiguousarray(verts, np.float64), piece.table, dist)
    per_bone = np.full((n, len(JOINTS)), np.inf)
    for p, prim in enumerate(piece.prims):
        if prim.kind == HALF_SPACE or prim.op != 0:
            continue
        per_bone[:, prim.bone] = np.minimum(per_bone[:, prim.bone], dist[:, p])
    d_min = per_bone.min(axis=1, keepdims=True)
    w = np.exp(-(per_bone - d_min) / SIGMA)
    a = _adjacency(n, tris)
    deg = np.asarray(a.sum(axis=1)).ravel()  # type: ignore[attr-defined]
    for _ in range(2):
        w = 0.5 * w + 0.5 * (a @ w) / np.maximum(deg, 1)[:, None]  # type: ignore[operator]
    return _top4(w)


class _Seams:
    """The body's arm and leg seams as smooth fields of the bind-pose position (metres).

    ``arm`` is positive on the arms: half the difference between the distance to the nearest
    flesh of any other bone and to the arms' flesh (the arm side of the surface equidistant
    from both, through the armpits and over the shoulders); ``leg`` likewise for the legs, and
    below :data:`LEG_SEAM_Y`, so that every shirt hem (0.95-1.01 m) runs round the trunk
    alone. Distances are the primitives' own (:func:`pedvr.render.implicit.prim_distances`):
    smooth, so are their differences, and their zero sets are smooth curves on the surface.
    """

    def __init__(self, prims: list[Prim]) -> None:
        flesh = [i for i, p in enumerate(prims) if p.kind != HALF_SPACE and p.op == 0]
        self.table = im.prim_table([prims[i] for i in flesh])
        arm = {_J[b] for b in ARM_BONES}
        leg = {_J[b] for b in LEG_BONES}
        bones = np.array([prims[i].bone for i in flesh])
        self.is_arm = np.isin(bones, list(arm))
        self.is_leg = np.isin(bones, list(leg))

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pts = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
        d = np.empty((len(pts), self.table.shape[0]))
        im.prim_distances(pts, self.table, d)
        d_arm = d[:, self.is_arm].min(axis=1)
        d_leg = d[:, self.is_leg].min(axis=1)
        d_core = d[:, ~(self.is_arm | self.is_leg)].min(axis=1)
        arm = 0.5 * (np.minimum(d_core, d_leg) - d_arm)
        leg = np.minimum(0.5 * (np.minimum(d_core, d_arm) - d_leg), LEG_SEAM_Y - pts[:, 1])
        return arm, leg


def cut_along(verts: np.ndarray, tris: np.ndarray, field: Callable[[np.ndarray], np.ndarray], *,
              snap: float = SEAM_SNAP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the triangles that ``field``'s zero set crosses, so that it runs along mesh edges.

    ``field(points (M, 3)) -> (M,)`` is evaluated at the vertices; where an edge's ends
    differ in sign the crossing is found by bisection on the field itself (so the new vertices
    lie on the zero set, not on a linear guess), unless it falls within ``snap`` of the edge's
    length from an end, which then counts as on the zero set. A triangle with one vertex on
    each side and one on the set becomes two, one with a vertex alone on its side three; new
    vertices are shared by the triangles on both sides of their edge and winding is kept, so a
    closed oriented surface stays one. Returns the vertices (old first), the triangles, and
    which vertices lie on the zero set.
    """
    verts = np.asarray(verts, np.float64)
    tris = np.asarray(tris, np.int64)
    f = np.asarray(field(verts), np.float64)
    on = f == 0.0
    # Edges that cross; crossings near an end snap to that end.
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    fa, fb = f[e[:, 0]], f[e[:, 1]]
    cross = (fa * fb < 0) & ~on[e[:, 0]] & ~on[e[:, 1]]
    t = np.where(cross, fa / np.where(cross, fa - fb, 1.0), 0.5)
    on[e[cross & (t < snap), 0]] = True
    on[e[cross & (t > 1.0 - snap), 1]] = True
    sign = np.where(on, 0, np.sign(f)).astype(np.int64)
    cross = (sign[e[:, 0]] * sign[e[:, 1]]) < 0
    ce = e[cross]
    # Bisection along each crossing edge on the true field.
    a, b = verts[ce[:, 0]], verts[ce[:, 1]]
    lo, hi = np.zeros(len(ce)), np.ones(len(ce))
    s0 = sign[ce[:, 0]]
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        fm = np.asarray(field(a + (b - a) * mid[:, None]))
        same = np.sign(fm) == s0
        lo, hi = np.where(same, mid, lo), np.where(same, hi, mid)
    t = 0.5 * (lo + hi)
    new = a + (b - a) * t[:, None]
    n0 = len(verts)
    key = ce[:, 0] * n0 + ce[:, 1]
    order = np.argsort(key)
    key, ids = key[order], (n0 + np.arange(len(ce)))[order]

    def point(i: np.ndarray, j: np.ndarray) -> np.ndarray:
        k = np.minimum(i, j) * n0 + np.maximum(i, j)
        return ids[np.searchsorted(key, k)]

    sg = sign[tris]
    out = [tris[~((sg == 1).any(axis=1) & (sg == -1).any(axis=1))]]
    split = tris[(sg == 1).any(axis=1) & (sg == -1).any(axis=1)]
    ss = sign[split]
    # Rotate each split triangle so that its first vertex is the one alone (on the set or on its side).
    lone = np.where((ss == 0).any(axis=1), np.argmax(ss == 0, axis=1),
                    np.argmax(ss == -np.sign(ss.sum(axis=1, keepdims=True)), axis=1))
    r = np.stack([split[np.arange(len(split)), (lone + k) % 3] for k in range(3)], axis=1)
    zero = sign[r[:, 0]] == 0
    v0, v1, v2 = r[zero, 0], r[zero, 1], r[zero, 2]
    p12 = point(v1, v2)
    out += [np.stack([v0, v1, p12], 1), np.stack([v0, p12, v2], 1)]
    v0, v1, v2 = r[~zero, 0], r[~zero, 1], r[~zero, 2]
    p01, p02 = point(v0, v1), point(v0, v2)
    out += [np.stack([v0, p01, p02], 1), np.stack([p01, v1, v2], 1), np.stack([p01, v2, p02], 1)]
    on = np.concatenate([on, np.ones(len(ce), np.bool_)])
    return np.concatenate([verts, new]), np.concatenate(out), on


def _cut_seams(piece: _Piece, verts: np.ndarray,
               tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The body cut along its arm and leg seams (:class:`_Seams`): vertices (new ones pulled onto
    the surface), triangles (each wholly on one side of each seam, its last vertex off both
    seams where it has one: the vertex the shader's flat region comes from), the arm and leg
    seam fields (exactly 0 on the seams) and each vertex's region (ARM, LEG or TRUNK, by the
    fields' signs where the vertex is: for the rare sliver with all three vertices on seams)."""
    seams = _Seams(piece.prims)
    verts, tris, on_arm = cut_along(verts, tris, lambda p: seams(p)[0])
    verts, tris, on_leg = cut_along(verts, tris, lambda p: seams(p)[1])
    on_arm = np.concatenate([on_arm, np.zeros(len(verts) - len(on_arm), np.bool_)])
    moved = np.flatnonzero(on_arm | on_leg)
    p = verts[moved]
    for _ in range(3):  # onto the surface: the new vertices lie on chords
        p = p - im.field(p, piece.table)[:, None] * im.gradient(p, piece.table)
    verts = verts.copy()
    verts[moved] = p
    arm, leg = seams(verts)
    region = np.where(arm > 0, ARM, np.where(leg > 0, LEG, TRUNK)).astype(np.int32)
    arm[on_arm], leg[on_leg] = 0.0, 0.0
    off = np.minimum(np.abs(arm), np.abs(leg))
    last = np.argmax(off[tris], axis=1)
    tris = np.stack([tris[np.arange(len(tris)), (last + k) % 3] for k in (1, 2, 3)], axis=1)
    return verts, tris, arm, leg, region


def _regions(piece: _Piece, verts: np.ndarray, rest: np.ndarray,
             seams: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Region, the scalar ``t`` and the ``local`` vector of each vertex of a piece.

    Body (with its ``seams``: arm and leg fields, regions): ``t`` is the bind-pose height,
    ``local`` (arm seam field, leg seam field, fraction along the limb); eyes: the direction
    from the eye's centre;
    lids: the eye's centre, ``t`` the angle from the lid's margin; hair: the position
    relative to the head joint.
    """
    n = len(verts)
    local = np.zeros((n, 3))
    t = np.zeros(n)
    region = np.full(n, piece.prims[0].region, np.int32)
    if piece.name.startswith("eye"):
        local = verts - rest[piece.prims[0].bone]
    elif piece.name.startswith("hair"):
        local = verts - rest[_J["Head"]]
    elif piece.name.startswith("lid"):
        side = piece.name[-1]
        c = rest[_J[f"{side}Eye"]]
        local[:] = c
        q = verts - c
        alpha = np.arctan2(q[:, 1], q[:, 2])  # angle above the eye's axis
        t = np.abs(alpha - (LID_OPEN_UPPER if region[0] == LID_UPPER else LID_OPEN_LOWER))
    elif piece.name == "body":
        # One clothable surface, cut along the arm and leg seams (_cut_seams): region ARM, LEG or
        # TRUNK (flat in the shader: every triangle is wholly on one side and its last vertex
        # says which); local (arm seam field, leg seam field, fraction along the limb from
        # shoulder to wrist or hip to ankle on the vertex's side: linear, so that a sleeve or
        # trouser hem cuts the limb along a plane), the bind-pose height in t, z and x in uv
        # (the neckline, lips and brows, crowd.glsl).
        assert seams is not None
        arm, leg, region = seams
        t = verts[:, 1].copy()
        local[:, 0], local[:, 1] = arm, leg
        near_arm = arm >= leg  # seam vertices take the fraction of the limb they border
        for side, sgn in (("L", 1.0), ("R", -1.0)):
            on_side = verts[:, 0] * sgn >= 0
            for sel, a, b in ((near_arm, "Shoulder", "Wrist"), (~near_arm, "Hip", "Ankle")):
                pa, pb = rest[_J[f"{side}{a}"]], rest[_J[f"{side}{b}"]]
                e = pb - pa
                pick = on_side & sel
                local[pick, 2] = (verts[pick] - pa) @ e / (e @ e)
    return region, t, local


def _ambient_occlusion(verts: np.ndarray, normals: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Per-vertex occlusion from the field along the normal (Quilez's distance-field AO), 0.45–1."""
    occ = np.zeros(len(verts))
    for i in range(1, 6):
        h = 0.012 * i
        occ += (h - im.field(verts + normals * h, table)) * 0.6 ** i / h
    return np.clip(1.0 - 0.9 * occ, 0.45, 1.0)


def _project(verts: np.ndarray, table: np.ndarray, adjacency: object) -> np.ndarray:
    """Offsets ``(V, 3)`` that move each vertex to the nearest point of another field's surface
    (steps along that field's gradient), at most 6 cm, smoothed over the mesh so that
    neighbours move together (the shape offsets)."""
    p = np.asarray(verts, np.float64).copy()
    for _ in range(5):
        p -= im.field(p, table)[:, None] * im.gradient(p, table)
    d = p - verts
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    d *= np.minimum(1.0, 0.06 / np.maximum(norm, 1e-12))
    deg = np.maximum(np.asarray(adjacency.sum(axis=1)).ravel(), 1)  # type: ignore[attr-defined]
    for _ in range(2):
        d = 0.5 * d + 0.5 * (adjacency @ d) / deg[:, None]  # type: ignore[operator]
    return d


def _pieces() -> list[_Piece]:
    pieces: list[_Piece] = []
    body = body_prims(0.0, 0.5)
    table = im.prim_table(body)
    v, t = im.polygonise(table, *_body_grid())
    pieces.append(_Piece("body", table, body, v, t, ALWAYS, LOD_TRIANGLES["body"]))
    for k, style in enumerate(HAIR_STYLES):
        prims = hair_prims(style)
        table = im.prim_table(prims)
        lo, hi = np.array([-0.13, 1.3, -0.2]), np.array([0.13, 1.81, 0.16])
        v, t = im.polygonise(table, *_box_grid(lo, hi, 0.004))
        budget = LOD_TRIANGLES.get(f"hair_{style}", LOD_TRIANGLES["hair"])
        pieces.append(_Piece(f"hair_{style}", table, prims, v, t, k, budget))
    prims = skirt_prims()
    table = im.prim_table(prims)
    v, t = im.polygonise(table, *_box_grid(np.array([-0.3, 0.5, -0.25]), np.array([0.3, 1.04, 0.25]), 0.01))
    pieces.append(_Piece("skirt", table, prims, v, t, SKIRT_VARIANT, LOD_TRIANGLES["skirt"]))
    for side in "LR":
        prims = eye_prims(side)
        table = im.prim_table(prims)
        c = np.asarray(prims[0].a)
        v, t = im.polygonise(table, *_box_grid(c - 0.015, c + 0.015, 0.0008))
        pieces.append(_Piece(f"eye_{side}", table, prims, v, t, ALWAYS, LOD_TRIANGLES["eye"]))
        for upper in (True, False):
            prims = lid_prims(side, upper)
            table = im.prim_table(prims)
            v, t = im.polygonise(table, *_box_grid(c - 0.016, c + 0.016, 0.0005))
            name = f"lid_{'upper' if upper else 'lower'}_{side}"
            pieces.append(_Piece(name, table, prims, v, t, ALWAYS, LOD_TRIANGLES["lid"]))
    return pieces


def _finish(piece: _Piece, verts: np.ndarray, tris: np.ndarray, rest: np.ndarray,
            variants: dict[str, np.ndarray]) -> MeshLOD:
    seams = None
    if piece.name == "body":
        verts, tris, arm, leg, body_region = _cut_seams(piece, verts, tris)
        seams = (arm, leg, body_region)
    normals = im.gradient(verts, piece.table)
    out = np.zeros(len(verts), VERTEX_DTYPE)
    out["pos"], out["normal"] = verts, normals
    if piece.name == "body":
        adj = _adjacency(len(verts), tris)
        out["dsex"] = _project(verts, variants["female"], adj)
        out["dbuild"] = _project(verts, variants["heavy"], adj) - _project(verts, variants["slender"], adj)
    out["bones"], out["weights"] = _skin_weights(piece, verts, tris)
    out["region"], out["t"], out["local"] = _regions(piece, verts, rest, seams)
    out["ao"] = _ambient_occlusion(verts, normals, piece.table) if piece.name == "body" else 1.0
    if piece.name == "body":
        out["uv"] = verts[:, [2, 0]]  # bind-pose z, x: the neckline, lips and brows (crowd.glsl)
    out["variant"] = piece.variant
    return MeshLOD(vertices=out, triangles=tris.astype(np.uint32))


def build_procedural() -> CharacterMesh:
    """Generate the procedural character (about a second; see :func:`procedural_character`)."""
    rest = _rest(0.0, 0.5)
    variants = {name: im.prim_table(body_prims(s, b))
                for name, s, b in (("female", 1.0, 0.5), ("heavy", 0.0, 1.0), ("slender", 0.0, 0.0))}
    pieces = _pieces()
    lods = []
    for level in range(LEVELS):
        parts = []
        for piece in pieces:
            v, t = _decimate(piece.verts, piece.tris, piece.lod_tris[level])
            parts.append(_finish(piece, v, t, rest, variants))
        lods.append(_concat(parts))
    return CharacterMesh(name="procedural", lods=tuple(lods), lod_error=PROCEDURAL_LOD_ERROR)


def _surface_points(v: np.ndarray, t: np.ndarray, spacing: float) -> np.ndarray:
    """Points on the triangles ``t`` of vertices ``v``: the vertices and, on each triangle, a
    barycentric grid whose steps are at most ``spacing`` (every point of the surface is within
    0.58 · ``spacing`` of one)."""
    p = v[t]
    edge = np.max(np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2), axis=1)
    steps = np.maximum(np.ceil(edge / spacing), 1).astype(np.int64)
    out = [v[np.unique(t)]]
    for m in np.unique(steps):
        i, j = np.meshgrid(np.arange(m + 1), np.arange(m + 1), indexing="ij")
        keep = i + j <= m
        a, b = i[keep] / m, j[keep] / m
        q = p[steps == m]
        out.append((a[None, :, None] * q[:, None, 0] + b[None, :, None] * q[:, None, 1]
                    + (1.0 - a - b)[None, :, None] * q[:, None, 2]).reshape(-1, 3))
    return np.concatenate(out)


def lod_deviation(lods: Sequence[MeshLOD], *, spacing: float, max_points: int | None = None
                  ) -> tuple[float, ...]:
    """Each level's largest deviation (m) from level 0, in the bind pose: the two-sided Hausdorff
    distance between their surfaces, piece by piece (each hair style against itself), measured
    between points :func:`_surface_points` spreads ``spacing`` apart (so up to 0.6 · ``spacing``
    high, and the nearest-neighbour search, 5 % approximate, errs high too: on the side of finer
    levels). Most of a minute for the procedural character at
    1.5 mm. ``max_points`` widens the spacing where level 0's surface would need more points than
    that (about 1.15 · area / spacing²): a mesh of large triangles (a boxy avatar of 160 vertices
    took a minute and a half at 3 mm) is measured in seconds."""
    from scipy.spatial import cKDTree

    if max_points is not None:
        p = lods[0].vertices["pos"].astype(np.float64)[lods[0].triangles.astype(np.int64)]
        area = 0.5 * float(np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum())
        spacing = max(spacing, math.sqrt(1.15 * area / max_points))

    def pieces(lod: MeshLOD) -> dict[int, np.ndarray]:
        v = lod.vertices
        t = lod.triangles.astype(np.int64)
        var = v["variant"][t[:, 0]]
        pos = v["pos"].astype(np.float64)
        return {int(k): _surface_points(pos, t[var == k], spacing) for k in np.unique(var)}

    ref = pieces(lods[0])
    out = [0.0]
    for lod in lods[1:]:
        worst = 0.0
        for k, pts in pieces(lod).items():
            if k not in ref:
                raise ValueError(f"a level of detail has variant {k}, which level 0 has not")
            worst = max(worst, float(cKDTree(ref[k]).query(pts, eps=0.05)[0].max()),
                        float(cKDTree(pts).query(ref[k], eps=0.05)[0].max()))
        out.append(worst)
    return tuple(out)


def _concat(parts: list[MeshLOD]) -> MeshLOD:
    verts, tris, base = [], [], 0
    for p in parts:
        verts.append(p.vertices)
        tris.append(p.triangles.astype(np.int64) + base)
        base += len(p.vertices)
    return MeshLOD(vertices=np.concatenate(verts), triangles=np.concatenate(tris).astype(np.uint32))


def _cache_dir() -> Path:
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root) / "pedvr"


def _cache_key() -> str:
    h = hashlib.sha256(f"v{MESH_VERSION}".encode())
    for mod in (im.__file__, __file__, sk.__file__):
        h.update(Path(mod).read_bytes())
    return h.hexdigest()[:16]


@lru_cache(maxsize=1)
def procedural_character() -> CharacterMesh:
    """The procedural character, from memory, else the user cache, else generated and cached."""
    path = _cache_dir() / f"procedural-{_cache_key()}.npz"
    try:
        with np.load(path) as data:
            lods = tuple(MeshLOD(vertices=data[f"v{i}"], triangles=data[f"t{i}"]) for i in range(LEVELS))
        if all(lod.vertices.dtype == VERTEX_DTYPE for lod in lods):
            return CharacterMesh(name="procedural", lods=lods, lod_error=PROCEDURAL_LOD_ERROR)
    except (OSError, KeyError, ValueError):
        pass
    mesh = build_procedural()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        arrays = {}
        for i, lod in enumerate(mesh.lods):
            arrays[f"v{i}"], arrays[f"t{i}"] = lod.vertices, lod.triangles
        np.savez(tmp, **arrays)  # type: ignore[arg-type]
        os.replace(tmp, path)
    except OSError:
        pass  # a read-only home: generate again next time
    return mesh
