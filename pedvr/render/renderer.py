"""The moderngl renderer: environment, the crowd in one instanced draw, views, overlays.

OpenGL 3.3 core; every program comes from a file in ``shaders/``
(:mod:`pedvr.render.shaders`). Per frame:

1. :meth:`Renderer.update` takes a :class:`~pedvr.render.snapshot.Snapshot`
   carrying the body layer's joint world matrices ``(N, 26, 4, 4)`` (agents
   of a hand-made snapshot without a body stand in the bind pose), scales
   each agent's joint frames by its body scale, and uploads bone matrices,
   palettes and shadow discs into float textures: one ``texture.write`` each.
2. :meth:`Renderer.draw_scene` draws floor, walls and obstacles, the red
   target sphere, the crowd and its contact shadows for one eye or, with two
   eyes, for both eyes in a single pass side by side (instance ``k`` draws
   for eye ``k % 2``; a clip plane cuts each half). The crowd is a few draw
   calls whatever the number of agents or eyes: one per character, level of
   detail and piece of the mesh that someone wears (the body, each hair
   style, the skirt: :func:`~pedvr.render.crowd.draw_plan`), each agent at
   the level its distance and the view's pixels call for
   (:func:`~pedvr.render.crowd.lod_levels`), and only the agents that may
   show in one of the eyes (:func:`~pedvr.render.crowd.in_views`). The key
   light's shadow map draws the agents in its box at a level as coarse as its
   texels allow (:func:`~pedvr.render.crowd.shadow_level`), depth only
   (``shaders/crowd_depth.glsl``).
3. Overlays: :meth:`draw_overhead` (debug view), :meth:`draw_panel` (HUD,
   questionnaires), :meth:`draw_anaglyph`, :meth:`draw_vignette`.

``draw_calls`` counts the draw calls issued since :meth:`begin_frame`.
Colour is computed in linear light and encoded to sRGB in the shader unless
the target encodes itself (an sRGB swapchain with ``GL_FRAMEBUFFER_SRGB``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import moderngl
import numpy as np

from pedvr.errors import BackendUnavailableError
from pedvr.etiquette.doors import DoorLeaves
from pedvr.render.bodymesh import (
    ALWAYS,
    SKIRT_VARIANT,
    VERTEX_ATTRIBUTES,
    VERTEX_DTYPE,
    VERTEX_FORMAT,
    CharacterMesh,
    lod_deviation,
    procedural_character,
)
from pedvr.render.carried import carried_vertices
from pedvr.render.carried import frames as carried_frames
from pedvr.render.crowd import (
    LOOK_TEXELS,
    N_JOINTS,
    ORDER_ROWS,
    SKIN_TEXELS,
    Blinks,
    Draw,
    Looks,
    Piece,
    _hash01,
    agent_looks,
    bind_joints,
    draw_plan,
    eye_directions,
    in_views,
    lod_levels,
    look_rows,
    mesh_pieces,
    pixels_per_radian,
    shadow_level,
    skin_rows,
)
from pedvr.render.environment import (
    ENV_DTYPE,
    ENV_FORMAT,
    FLOOR_PATTERNS,
    ExhibitShape,
    door_leaf_vertices,
    environment_mesh,
    exhibit_shapes,
    place_leaves,
    sphere_vertices,
)
from pedvr.render.figures import default_dims, standing_bones
from pedvr.render.lighting import SHADOW_HALF_EXTENT, SHADOW_MAP_SIZE, light_view_projection
from pedvr.render.math3d import EyeView, overhead_transform
from pedvr.render.overhead import BACKGROUND, disc_fan, frame_geometry, static_triangles
from pedvr.render.shaders import SHADER_DIR, compile_program
from pedvr.render.shaders import set_uniform as _set
from pedvr.render.snapshot import SPHERE_HEIGHT, TARGET_RADIUS, Snapshot
from pedvr.scene.config import SceneConfig, WorldConfig

GL_CLIP_DISTANCE0 = 0x3000
GL_FRAMEBUFFER_SRGB = 0x8DB9
SKY_LINEAR = (0.62, 0.74, 0.88)  # the shaders' SKY: the clear colour matches the fog
TARGET_ALPHA = 0.35  # the route target's opacity where it is in front of a pedestrian


def srgb_encode_rgb(c: Sequence[float]) -> tuple[float, ...]:
    out = []
    for x in c:
        x = min(max(float(x), 0.0), 1.0)
        out.append(x * 12.92 if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055)
    return tuple(out)


def create_offscreen_context() -> moderngl.Context:
    """A standalone EGL context (no display needed: Mesa llvmpipe on CI); one clear error if none."""
    try:
        return moderngl.create_context(standalone=True, backend="egl", require=330)  # type: ignore[arg-type]
    except Exception as exc:  # glcontext raises plain Exception with the EGL cause
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise BackendUnavailableError(
            f"cannot create an offscreen OpenGL 3.3 context through EGL: {reason}; "
            "install Mesa's EGL (libegl1, libgl1-mesa-dri) or run without --frames/--video"
        ) from None


def gl_renderer_name(ctx: moderngl.Context) -> str:
    return str(ctx.info.get("GL_RENDERER", "unknown"))


@dataclass
class FrameStats:
    """CPU time of the last :meth:`Renderer.update` (ms) and draw calls since :meth:`begin_frame`."""

    pose_ms: float = 0.0
    upload_ms: float = 0.0
    draw_calls: int = 0
    agents_drawn: int = 0
    vertices: int = 0  # crowd vertices submitted since begin_frame (all views and the shadow pass)
    lod_agents: tuple[int, ...] = ()  # agents at each level of detail in the last view drawn (those in it)


class OffscreenTarget:
    """Colour (RGBA8) + depth framebuffer of ``size`` ``(width, height)``; :meth:`read`: top row first.

    With ``samples`` > 0 it is multisampled (issue 16: the headless frames and video use 4×);
    :meth:`read` and :attr:`resolved` resolve it into a plain texture first.
    """

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], *, samples: int = 0) -> None:
        self.size = size
        self.ctx = ctx
        self.samples = samples
        self.color = ctx.texture(size, 4, samples=samples)
        self.depth = ctx.depth_renderbuffer(size, samples=samples)
        self.fbo = ctx.framebuffer(color_attachments=[self.color], depth_attachment=self.depth)
        self._resolve_tex: moderngl.Texture | None = None
        self._resolve_fbo: moderngl.Framebuffer | None = None
        if samples:
            self._resolve_tex = ctx.texture(size, 4)
            self._resolve_fbo = ctx.framebuffer(color_attachments=[self._resolve_tex])

    @property
    def resolved(self) -> moderngl.Texture:
        """The colour as a single-sampled texture (resolved now when multisampled)."""
        if self._resolve_fbo is None or self._resolve_tex is None:
            return self.color
        self.ctx.copy_framebuffer(self._resolve_fbo, self.fbo)
        return self._resolve_tex

    def read(self, *, components: int = 3) -> np.ndarray:
        fbo = self.fbo
        if self._resolve_fbo is not None:
            self.ctx.copy_framebuffer(self._resolve_fbo, self.fbo)
            fbo = self._resolve_fbo
        data = fbo.read(components=components, alignment=1)
        img = np.frombuffer(data, dtype=np.uint8).reshape(self.size[1], self.size[0], components)
        return img[::-1].copy()

    def release(self) -> None:
        self.fbo.release()
        self.color.release()
        self.depth.release()
        if self._resolve_fbo is not None and self._resolve_tex is not None:
            self._resolve_fbo.release()
            self._resolve_tex.release()


class Renderer:
    """Draws one world and its crowd. Keyword-only options:

    ``shader_dir``: where the GLSL files are. ``hide_user``: do not draw the
    user's own body (first person, issue 4). ``shadows``: the key light's
    shadow map (issue 16; off, only the contact shadows stay).
    ``shadow_map_size``: its texels per side. ``characters``: meshes to draw
    agents with (default: the procedural character alone);
    ``Snapshot.character`` picks one per agent.
    """

    def __init__(
        self,
        ctx: moderngl.Context,
        *,
        world: WorldConfig,
        shader_dir: Path = SHADER_DIR,
        hide_user: bool = True,
        shadows: bool = True,
        shadow_map_size: int = SHADOW_MAP_SIZE,
        characters: Sequence[CharacterMesh] | None = None,
        profile_characters: Sequence[Sequence[int]] = (),
        exhibits: Sequence[ExhibitShape] = (),
    ) -> None:
        self.ctx = ctx
        # Flat attributes come from a triangle's last vertex (GL's default, said here because the
        # body's regions depend on it: bodymesh._cut_seams puts a vertex off the seams last).
        ctx.provoking_vertex = moderngl.LAST_VERTEX_CONVENTION
        self.world = world
        self.hide_user = hide_user
        self.shadows = shadows
        self.stats = FrameStats()
        self._n = 0
        self._capacity = 0
        self._sphere: np.ndarray | None = None
        self._snap: Snapshot | None = None
        self._rows = np.zeros(0, np.int64)
        self._drawn_pos = np.zeros((0, 2))
        self._drawn_char = np.zeros(0, np.int64)
        self._drawn_scale = np.zeros(0)
        self._looks_key: tuple[bytes, bytes, bytes] | None = None
        self._looks_cache: tuple[Looks, np.ndarray] | None = None
        self._drawn_style = np.zeros(0, np.int64)
        self._drawn_skirt = np.zeros(0, np.bool_)
        self._blinks = Blinks()
        self._shadow_dirty = True
        self._light_vp = np.eye(4)

        names = ("crowd", "crowd_depth", "environment", "shadow", "overlay", "discs", "panel", "composite")
        self.programs = {n: compile_program(ctx, f"{n}.glsl", shader_dir=shader_dir) for n in names}
        p = self.programs

        self.characters: list[CharacterMesh] = list(characters) if characters else [procedural_character()]
        self._profile_chars = [np.asarray(c, np.int64) for c in profile_characters]
        # Per character and level: the view's and the shadow map's vertex arrays over one vertex
        # buffer and one index buffer ordered by piece (crowd.mesh_pieces), and the pieces.
        self._char_vaos: list[list[tuple[moderngl.VertexArray, moderngl.VertexArray]]] = []
        self._char_pieces: list[list[tuple[Piece, ...]]] = []
        self._char_buffers: list[moderngl.Buffer] = []
        self._char_textures: list[moderngl.Texture | None] = []
        view_layout = _vertex_layout(p["crowd"])
        depth_layout = _vertex_layout(p["crowd_depth"])
        for ch in self.characters:
            vaos, pieces = [], []
            for lod in ch.lods:
                tris, parts = mesh_pieces(lod.triangles, lod.vertices["variant"])
                vbo = ctx.buffer(lod.vertices.tobytes())
                ibo = ctx.buffer(tris.tobytes())
                self._char_buffers += [vbo, ibo]
                vaos.append(tuple(ctx.vertex_array(prog, [(vbo, *layout)], index_buffer=ibo,
                                                   index_element_size=4)
                                  for prog, layout in ((p["crowd"], view_layout),
                                                       (p["crowd_depth"], depth_layout))))
                pieces.append(parts)
            self._char_vaos.append(vaos)  # type: ignore[arg-type]
            self._char_pieces.append(pieces)
            tex = None
            if ch.texture is not None:
                img = np.ascontiguousarray(ch.texture, np.uint8)  # glTF's v runs down the image, as GL's t
                tex = ctx.texture((img.shape[1], img.shape[0]), 4, img.tobytes())
                tex.build_mipmaps()
                tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            self._char_textures.append(tex)
        # Each level's deviation from level 0 (m), which picks the distances it is drawn from.
        self._lod_error = [ch.lod_error or lod_deviation(ch.lods, spacing=0.003, max_points=50_000)
                           for ch in self.characters]
        self._white = ctx.texture((1, 1), 4, bytes([255, 255, 255, 255]))
        self.crowd_vertices = self.characters[0].vertex_counts[0]

        env = environment_mesh(world, exhibits)
        self._floor_vbo = ctx.buffer(env.floor.tobytes())
        self._solid_vbo = ctx.buffer(env.solids.tobytes())
        fmt = ENV_FORMAT
        self._floor_vao = ctx.vertex_array(p["environment"], [(self._floor_vbo, *fmt)])
        self._solid_vao = ctx.vertex_array(p["environment"], [(self._solid_vbo, *fmt)])
        self._ceiling_count = len(env.ceiling)
        self._ceiling_vbo = ctx.buffer(env.ceiling.tobytes() if len(env.ceiling)
                                       else b"\0" * ENV_DTYPE.itemsize)
        self._ceiling_vao = ctx.vertex_array(p["environment"], [(self._ceiling_vbo, *fmt)])
        leaves = DoorLeaves.of_world(world)
        self._closed_doors = leaves.pose()
        self._leaf_local = [door_leaf_vertices(float(w), float(h))
                            for w, h in zip(leaves.length, leaves.height, strict=True)]
        placed = place_leaves(self._leaf_local, self._closed_doors)
        self._leaf_count = len(placed)
        self._leaf_vbo = ctx.buffer(placed.tobytes() if len(placed) else b"\0" * ENV_DTYPE.itemsize,
                                    dynamic=True)
        self._leaf_vao = ctx.vertex_array(p["environment"], [(self._leaf_vbo, *fmt)])
        # Boxes and prams the pedestrians carry (pedvr.render.carried): one dynamic buffer, one draw.
        self._carried_count = 0
        self._carried_vbo = ctx.buffer(reserve=ENV_DTYPE.itemsize * 4096, dynamic=True)
        self._carried_vao = ctx.vertex_array(p["environment"], [(self._carried_vbo, *fmt)])
        sphere = sphere_vertices()
        self._sphere_vbo = ctx.buffer(sphere.tobytes())
        self._sphere_vao = ctx.vertex_array(p["environment"], [(self._sphere_vbo, *fmt)])

        self._shadow_size = int(shadow_map_size)
        self._shadow_tex = ctx.depth_texture((self._shadow_size, self._shadow_size))
        self._shadow_tex.compare_func = "<="
        self._shadow_tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self._shadow_tex.repeat_x = self._shadow_tex.repeat_y = False
        self._shadow_fbo = ctx.framebuffer(depth_attachment=self._shadow_tex)

        quad = np.array([[-1, -1], [1, -1], [1, 1], [-1, -1], [1, 1], [-1, 1]], dtype=np.float32)
        self._quad_vbo = ctx.buffer(quad.tobytes())
        self._shadow_vao = ctx.vertex_array(p["shadow"], [(self._quad_vbo, "2f", "in_corner")])
        unit = (quad + 1) / 2
        self._unit_vbo = ctx.buffer(unit.astype(np.float32).tobytes())
        self._panel_vao = ctx.vertex_array(p["panel"], [(self._unit_vbo, "2f", "in_corner")])
        self._composite_vao = ctx.vertex_array(p["composite"], [(self._unit_vbo, "2f", "in_corner")])

        tris = static_triangles(world)
        self._ov_tri_vbo = ctx.buffer(tris.tobytes() if len(tris) else b"\0" * 24)
        self._ov_tri_count = len(tris)
        self._ov_tri_vao = ctx.vertex_array(p["overlay"], [(self._ov_tri_vbo, "2f 4f", "in_pos", "in_color")])
        self._ov_line_vbo = ctx.buffer(reserve=24 * 4096, dynamic=True)
        self._ov_line_vao = ctx.vertex_array(
            p["overlay"], [(self._ov_line_vbo, "2f 4f", "in_pos", "in_color")]
        )
        self._fan_vbo = ctx.buffer(disc_fan().tobytes())
        self._fan_count = len(disc_fan())
        self._disc_vbo = ctx.buffer(reserve=28 * 1024, dynamic=True)
        self._disc_vao = ctx.vertex_array(
            p["discs"],
            [(self._fan_vbo, "2f", "in_unit"), (self._disc_vbo, "3f 4f/i", "in_disc", "in_disc_color")],
        )
        self._panel_textures: dict[tuple[int, int], moderngl.Texture] = {}
        self._ensure_capacity(64)

    # -- per-frame state -----------------------------------------------------------------------

    def _ensure_capacity(self, n: int) -> None:
        if n <= self._capacity:
            return
        cap = max(64, 1 << (n - 1).bit_length())
        limit = int(self.ctx.info.get("GL_MAX_TEXTURE_SIZE", 8192))
        if cap > limit:
            raise BackendUnavailableError(f"{n} agents: more than this GPU's texture height {limit} allows")
        for name in ("_skin", "_looks", "_discs", "_order"):
            old = getattr(self, name, None)
            if old is not None:
                old.release()
        self._skin = self.ctx.texture((SKIN_TEXELS, cap), 4, dtype="f4")
        self._looks = self.ctx.texture((LOOK_TEXELS, cap), 4, dtype="f4")
        self._discs = self.ctx.texture((1, cap), 4, dtype="f4")
        self._order = self.ctx.texture((cap, 2 * ORDER_ROWS), 1, dtype="i4")  # the views', the shadow map's
        for tex in (self._skin, self._looks, self._discs, self._order):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._skin_buf = np.zeros((cap, SKIN_TEXELS, 4), np.float32)
        self._capacity = cap

    def begin_frame(self) -> None:
        """Reset the per-frame draw-call and vertex counts."""
        self.stats.draw_calls = 0
        self.stats.vertices = 0

    @classmethod
    def for_scene(cls, ctx: moderngl.Context, scene: SceneConfig, **kw: object) -> Renderer:
        """A renderer for ``scene`` with the characters its profiles name (issue 16): the procedural
        one and every glTF/VRM file, loaded once; raises AvatarError naming a file that cannot be used."""
        from pedvr.render.avatars import load_avatar

        chars: list[CharacterMesh] = [procedural_character()]
        index: dict[str, int] = {"builtin": 0}
        table = []
        for prof in scene.profiles.values():
            picks = []
            for name in prof.characters or ("builtin",):
                if name not in index:
                    index[name] = len(chars)
                    chars.append(load_avatar(name, bone_map=scene.bone_map))
                picks.append(index[name])
            table.append(tuple(picks))
        exhibits = exhibit_shapes(scene.world, scene.behavior.objects)
        return cls(ctx, world=scene.world, characters=chars, profile_characters=table, exhibits=exhibits,
                   **kw)  # type: ignore[arg-type]

    def _by_profile(self, ids: np.ndarray, profile: np.ndarray) -> np.ndarray:
        """Each agent's character: one of its profile's, picked by its stable id (0 for the user)."""
        out = np.zeros(len(ids), np.int64)
        pick = _hash01(ids, 31)
        for p, choices in enumerate(self._profile_chars):
            sel = profile == p
            if sel.any():
                out[sel] = choices[np.minimum((pick[sel] * len(choices)).astype(np.int64), len(choices) - 1)]
        return out

    def _looks_for(self, ids: np.ndarray, dims: np.ndarray, char: np.ndarray) -> tuple[Looks, np.ndarray]:
        """Looks and bind-pose joints of the drawn agents, recomputed only when the crowd changes."""
        key = (ids.tobytes(), dims.tobytes(), char.tobytes())
        if key != self._looks_key or self._looks_cache is None:
            rest = bind_joints(dims).astype(np.float32)
            for c, ch in enumerate(self.characters):
                if ch.rest is not None:
                    rest[char == c] = ch.rest
            looks = agent_looks(ids, dims)
            self._looks_cache = (looks, rest)
            self._drawn_style = np.asarray(looks.hair_style, np.int64)
            self._drawn_skirt = np.asarray(looks.skirt, np.bool_)
            self._looks_key = key
        return self._looks_cache

    def update(self, snap: Snapshot) -> None:
        """Upload the crowd of ``snap``: skinning matrices, looks (with blinks) and contact-shadow discs."""
        t0 = time.perf_counter()
        show = ~snap.is_user if self.hide_user else np.ones(len(snap), np.bool_)
        rows = np.flatnonzero(show)
        n = int(rows.size)
        dims = default_dims(snap.ids) if snap.dims is None else np.asarray(snap.dims, np.float64)
        if snap.bones is None:
            world = standing_bones(snap.pos, snap.heading, dims)
        else:
            world = np.asarray(snap.bones)
            if world.shape != (len(snap), N_JOINTS, 4, 4):
                raise ValueError(f"bones shape {world.shape}: expected ({len(snap)}, {N_JOINTS}, 4, 4)")
        world = np.ascontiguousarray(world, np.float32)
        char = np.zeros(n, np.int64)
        if snap.character is None and snap.profile is not None and self._profile_chars:
            char = self._by_profile(snap.ids[rows], np.asarray(snap.profile, np.int64)[rows])
        elif snap.character is not None:
            char = np.asarray(snap.character, np.int64)[rows]
            if n and (char.min() < 0 or char.max() >= len(self.characters)):
                raise ValueError(f"character index {int(char.max())}: this renderer has "
                                 f"{len(self.characters)} characters")
        ids, d = snap.ids[rows], dims[rows]
        looks, rest = self._looks_for(ids, d, char)
        self._ensure_capacity(max(n, 1))
        blink = self._blinks.update(ids, float(snap.t), eye_directions(world, rows)) if n else np.zeros(0)
        if n:
            skin_rows(world, rows, d[:, 3].astype(np.float32), rest, self._skin_buf)
        lk = look_rows(looks, d, blink) if n else np.zeros((0, LOOK_TEXELS, 4), np.float32)
        t1 = time.perf_counter()
        if n:
            self._skin.write(self._skin_buf[:n].tobytes(), viewport=(0, 0, SKIN_TEXELS, n))
            self._looks.write(lk.tobytes(), viewport=(0, 0, LOOK_TEXELS, n))
            discs = np.zeros((n, 4), np.float32)
            discs[:, :2], discs[:, 2], discs[:, 3] = snap.pos[rows], snap.radius[rows], 1.0
            self._discs.write(discs.tobytes(), viewport=(0, 0, 1, n))
        if self._leaf_count:
            pose = self._closed_doors if snap.doors is None else np.asarray(snap.doors, np.float64)
            if pose.shape != self._closed_doors.shape:
                raise ValueError(f"doors shape {pose.shape}: expected {self._closed_doors.shape}")
            self._leaf_vbo.write(place_leaves(self._leaf_local, pose).tobytes())
        self._carried_count = 0
        if snap.carrying is not None and n and np.any(np.asarray(snap.carrying)[rows]):
            kind = np.asarray(snap.carrying)[rows]
            given = None if snap.carry_frame is None else np.asarray(snap.carry_frame)[rows]
            frame = carried_frames(kind, given, snap.pos[rows], snap.heading[rows], d[:, 3])
            carried = carried_vertices(kind, frame, d[:, 3])
            self._carried_vbo, grew = _fit(self.ctx, self._carried_vbo, carried.tobytes())
            if grew:
                self._carried_vao.release()
                self._carried_vao = self.ctx.vertex_array(self.programs["environment"],
                                                          [(self._carried_vbo, *ENV_FORMAT)])
            self._carried_count = len(carried)
        self._n = n
        self._rows = rows
        self._drawn_pos = np.asarray(snap.pos, np.float64)[rows]
        self._drawn_char = char
        self._drawn_scale = d[:, 3].astype(np.float64)
        self._sphere = None if snap.sphere is None else np.asarray(snap.sphere, dtype=np.float64)
        self._snap = snap
        self._shadow_dirty = True
        t2 = time.perf_counter()
        self.stats.pose_ms = (t1 - t0) * 1e3
        self.stats.upload_ms = (t2 - t1) * 1e3
        self.stats.agents_drawn = n

    # -- 3D views ------------------------------------------------------------------------------

    def _render(self, vao: moderngl.VertexArray, **kw: object) -> None:
        vao.render(**kw)  # type: ignore[arg-type]
        self.stats.draw_calls += 1

    def _common(self, prog: moderngl.Program, eyes: Sequence[EyeView], srgb_encode: bool, *,
                shadow_pass: bool = False) -> None:
        vp = np.zeros((2, 4, 4), np.float32)
        pos = np.zeros((2, 3), np.float32)
        for k in range(2):
            e = eyes[min(k, len(eyes) - 1)]
            vp[k] = e.view_projection.T  # GL column-major
            pos[k] = e.position
        _write(prog, "u_view_proj", vp.tobytes())
        _write(prog, "u_eye_pos", pos.tobytes())
        _write(prog, "u_light_vp", self._light_vp.T.astype(np.float32).tobytes())
        _set(prog, "u_eyes", 1 if shadow_pass else len(eyes))
        _set(prog, "u_srgb_encode", srgb_encode)
        _set(prog, "u_shadow_pass", shadow_pass)
        _set(prog, "u_shadows", self.shadows and not shadow_pass)
        _set(prog, "u_shadow_map", 7)

    def _draw_crowd(self, draws: list[Draw], eyes: int, *, shadow_pass: bool) -> None:
        """Issue ``draws`` (of the views' order rows, or the shadow map's) for ``eyes`` eyes."""
        prog = self.programs["crowd_depth" if shadow_pass else "crowd"]
        _set(prog, "u_skin", 0)
        _set(prog, "u_looks", 1)
        _set(prog, "u_order", 2)
        _set(prog, "u_albedo", 3)
        _set(prog, "u_base_color", (1.0, 1.0, 1.0, 1.0))
        self._skin.use(location=0)
        self._looks.use(location=1)
        self._order.use(location=2)
        row0 = ORDER_ROWS if shadow_pass else 0
        for d in draws:
            vao = self._char_vaos[d.character][d.level][1 if shadow_pass else 0]
            piece = self._char_pieces[d.character][d.level][d.piece]
            if not shadow_pass:
                (self._char_textures[d.character] or self._white).use(location=3)
            _set(prog, "u_base", d.first)
            _set(prog, "u_order_row", row0 + d.row)
            self._render(vao, vertices=piece.indices, first=piece.first, instances=d.count * eyes)
            self.stats.vertices += piece.vertices * d.count * eyes

    def _plan(self, lod: np.ndarray, *, shadow_pass: bool, agents: np.ndarray | None = None) -> list[Draw]:
        """The draws of the crowd's ``agents`` (rows; all by default) at levels ``lod`` (one per
        agent drawn); their instance order into the pass's rows."""
        a = np.arange(self._n) if agents is None else agents
        order, draws = draw_plan(self._drawn_char[a], lod, self._drawn_style[a], self._drawn_skirt[a],
                                 self._char_pieces, always=ALWAYS, skirt_variant=SKIRT_VARIANT)
        order = a[order].astype(np.int32)
        row0 = ORDER_ROWS if shadow_pass else 0
        self._order.write(order.tobytes(), viewport=(0, row0, order.shape[1], ORDER_ROWS))
        return draws

    def _view_draws(self, eyes: Sequence[EyeView], viewport_height: int) -> list[Draw]:
        """The crowd's draws for ``eyes``: the agents that may show in one of them (crowd.in_views),
        each at the level its distance from the eyes and the view's pixels per radian call for
        (crowd.lod_levels)."""
        viewer = np.mean([e.position for e in eyes], axis=0)
        ppr = pixels_per_radian(eyes[0].projection, viewport_height)
        seen = np.flatnonzero(in_views(self._drawn_pos, self._drawn_scale, [e.view_projection for e in eyes]))
        char = self._drawn_char[seen]
        lod = np.zeros(len(seen), np.int64)
        for c, errors in enumerate(self._lod_error):
            mine = char == c
            if mine.any():
                lod[mine] = lod_levels(self._drawn_pos[seen[mine]], np.array([viewer[0], viewer[2]]),
                                       pixels_per_radian=ppr, errors=errors)
        levels = max(len(e) for e in self._lod_error)
        self.stats.lod_agents = tuple(np.bincount(lod, minlength=levels).tolist())
        return self._plan(lod, shadow_pass=False, agents=seen)

    def _shadow_map(self, eyes: Sequence[EyeView]) -> None:
        """Render the key light's depth around the first eye into the shadow map (once per update).

        The crowd casts at each character's coarsest level within two of the map's texels
        (crowd.shadow_level), depth only (``crowd_depth.glsl``), and only the agents inside the
        light's box (crowd.in_views): one outside casts outside it."""
        ctx = self.ctx
        self._light_vp = light_view_projection(np.asarray(eyes[0].position) * np.array([1.0, 0.0, 1.0]),
                                               size=self._shadow_size)
        self._shadow_fbo.use()
        self._shadow_fbo.viewport = (0, 0, self._shadow_size, self._shadow_size)
        self._shadow_fbo.clear(depth=1.0)
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)  # thin walls and open shells cast from both sides
        env = self.programs["environment"]
        self._common(env, eyes, True, shadow_pass=True)
        _write(env, "u_model", np.eye(4, dtype=np.float32).tobytes())
        self._render(self._solid_vao)
        if self._leaf_count:
            self._render(self._leaf_vao)
        if self._carried_count:
            self._render(self._carried_vao, vertices=self._carried_count)
        if self._n:
            texel = 2.0 * SHADOW_HALF_EXTENT / self._shadow_size
            level = np.array([shadow_level(e, texel) for e in self._lod_error], np.int64)
            lit = np.flatnonzero(in_views(self._drawn_pos, self._drawn_scale, [self._light_vp]))
            draws = self._plan(level[self._drawn_char[lit]], shadow_pass=True, agents=lit)
            _write(self.programs["crowd_depth"], "u_light_vp", self._light_vp.T.astype(np.float32).tobytes())
            self._draw_crowd(draws, 1, shadow_pass=True)
        self._shadow_dirty = False

    def draw_scene(
        self,
        eyes: Sequence[EyeView],
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int] | None = None,
        srgb_encode: bool = True,
        clear: bool = True,
    ) -> None:
        """Draw the 3D scene for one eye, or two eyes side by side in one pass, into ``viewport``.

        The first call after :meth:`update` also renders the key light's
        shadow map around the eyes (later calls for other eyes reuse it).
        """
        if len(eyes) not in (1, 2):
            raise ValueError(f"{len(eyes)} eyes: expected 1 or 2")
        ctx = self.ctx
        if self.shadows and self._shadow_dirty:
            self._shadow_map(eyes)
        vp = viewport or (0, 0, *framebuffer.size)
        draws = self._view_draws(eyes, vp[3]) if self._n else []
        framebuffer.use()
        framebuffer.viewport = vp
        if clear:
            sky = srgb_encode_rgb(SKY_LINEAR) if srgb_encode else SKY_LINEAR
            framebuffer.scissor = vp
            framebuffer.clear(red=sky[0], green=sky[1], blue=sky[2], alpha=1.0, depth=1.0)
            framebuffer.scissor = None  # type: ignore[assignment]
        ctx.enable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.disable(moderngl.BLEND)
        framebuffer.depth_mask = True
        ctx.enable_direct(GL_CLIP_DISTANCE0)
        self._shadow_tex.use(location=7)
        k = len(eyes)
        env = self.programs["environment"]
        self._common(env, eyes, srgb_encode)
        _write(env, "u_model", np.eye(4, dtype=np.float32).tobytes())
        _set(env, "u_emissive", (0.0, 0.0, 0.0))
        _set(env, "u_alpha", 1.0)
        _set(env, "u_floor", FLOOR_PATTERNS.get(self.world.floor, 0))
        _set(env, "u_pattern", 1)
        self._render(self._floor_vao, instances=k)
        _set(env, "u_pattern", 0)
        self._render(self._solid_vao, instances=k)
        if self._ceiling_count:
            self._render(self._ceiling_vao, instances=k)
        if self._leaf_count:
            self._render(self._leaf_vao, instances=k)
        if self._carried_count:
            self._render(self._carried_vao, vertices=self._carried_count, instances=k)
        sphere_model = None
        if self._sphere is not None:
            # The route target, first opaque without writing depth: pedestrians behind it cover it...
            sphere_model = np.eye(4, dtype=np.float32)
            sphere_model[:3, :3] *= 2 * TARGET_RADIUS
            sphere_model[:3, 3] = (self._sphere[0], SPHERE_HEIGHT, self._sphere[1])
            _write(env, "u_model", sphere_model.T.tobytes())
            _set(env, "u_emissive", (0.22, 0.02, 0.0))
            framebuffer.depth_mask = False
            self._render(self._sphere_vao, instances=k)
            framebuffer.depth_mask = True
            _write(env, "u_model", np.eye(4, dtype=np.float32).tobytes())
            _set(env, "u_emissive", (0.0, 0.0, 0.0))
        if self._n:
            self._common(self.programs["crowd"], eyes, srgb_encode)
            self._draw_crowd(draws, k, shadow_pass=False)
            shadow = self.programs["shadow"]
            self._common(shadow, eyes, srgb_encode)
            _set(shadow, "u_discs", 4)
            self._discs.use(location=4)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            framebuffer.depth_mask = False
            self._render(self._shadow_vao, instances=self._n * k)
            framebuffer.depth_mask = True
            ctx.disable(moderngl.BLEND)
        if sphere_model is not None:
            # ...then blended over whatever it is in front of: semi-transparent over a pedestrian,
            # unchanged over the background it already covers (issue 16).
            _write(env, "u_model", sphere_model.T.tobytes())
            _set(env, "u_emissive", (0.22, 0.02, 0.0))
            _set(env, "u_alpha", TARGET_ALPHA)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            framebuffer.depth_mask = False
            self._render(self._sphere_vao, instances=k)
            framebuffer.depth_mask = True
            ctx.disable(moderngl.BLEND)
            _set(env, "u_alpha", 1.0)
        ctx.disable_direct(GL_CLIP_DISTANCE0)
        ctx.disable(moderngl.CULL_FACE)

    # -- 2D views and overlays -----------------------------------------------------------------

    def draw_overhead(
        self,
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int] | None = None,
        center: tuple[float, float] | None = None,
        extent: float | None = None,
        snap: Snapshot | None = None,
    ) -> None:
        """The overhead debug view of the last updated snapshot (or ``snap``) into ``viewport``."""
        snap = snap or self._snap
        if snap is None:
            raise ValueError("draw_overhead before update(): no snapshot to draw")
        ctx = self.ctx
        framebuffer.use()
        vp = viewport or (0, 0, *framebuffer.size)
        framebuffer.viewport = vp
        framebuffer.scissor = vp
        framebuffer.clear(red=BACKGROUND[0], green=BACKGROUND[1], blue=BACKGROUND[2], alpha=1.0)
        framebuffer.scissor = None  # type: ignore[assignment]
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        (x0, y0), (x1, y1) = self.world.bounds
        c = center or ((x0 + x1) / 2, (y0 + y1) / 2)
        aspect = vp[2] / max(vp[3], 1)
        ext = extent or max((x1 - x0) / max(aspect, 1e-6), y1 - y0) * 1.08
        if aspect < 1.0:
            ext = extent or max(x1 - x0, (y1 - y0) * aspect) * 1.08
        m = overhead_transform(center=c, extent=ext, aspect=aspect).astype(np.float32)
        for name in ("overlay", "discs"):
            _write(self.programs[name], "u_map", m.T.tobytes())
        if self._ov_tri_count:
            self._render(self._ov_tri_vao, mode=moderngl.TRIANGLES, vertices=self._ov_tri_count)
        lines, discs = frame_geometry(self.world, snap)
        if len(discs):
            self._disc_vbo, grew = _fit(ctx, self._disc_vbo, discs.tobytes())
            if grew:
                self._disc_vao.release()
                self._disc_vao = ctx.vertex_array(
                    self.programs["discs"],
                    [
                        (self._fan_vbo, "2f", "in_unit"),
                        (self._disc_vbo, "3f 4f/i", "in_disc", "in_disc_color"),
                    ],
                )
            self._render(
                self._disc_vao, mode=moderngl.TRIANGLES, vertices=self._fan_count, instances=len(discs)
            )
        if len(lines):
            self._ov_line_vbo, grew = _fit(ctx, self._ov_line_vbo, lines.tobytes())
            if grew:
                self._ov_line_vao.release()
                self._ov_line_vao = ctx.vertex_array(
                    self.programs["overlay"], [(self._ov_line_vbo, "2f 4f", "in_pos", "in_color")]
                )
            self._render(self._ov_line_vao, mode=moderngl.LINES, vertices=len(lines))
        ctx.disable(moderngl.BLEND)

    def draw_panel(
        self,
        image: np.ndarray,
        *,
        framebuffer: moderngl.Framebuffer,
        x: int,
        y: int,
        viewport: tuple[int, int, int, int] | None = None,
    ) -> None:
        """Draw an RGBA ``uint8`` image ``(H, W, 4)`` with its top-left corner at pixel ``(x, y)``."""
        h, w = image.shape[:2]
        tex = self._panel_textures.get((w, h))
        if tex is None:
            tex = self.ctx.texture((w, h), 4)
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self._panel_textures[(w, h)] = tex
        tex.write(np.ascontiguousarray(image, dtype=np.uint8).tobytes())
        framebuffer.use()
        vp = viewport or (0, 0, *framebuffer.size)
        framebuffer.viewport = vp
        vw, vh = vp[2], vp[3]
        x0, x1 = 2 * x / vw - 1, 2 * (x + w) / vw - 1
        y1, y0 = 1 - 2 * y / vh, 1 - 2 * (y + h) / vh
        prog = self.programs["panel"]
        _set(prog, "u_rect", (x0, y0, x1, y1))
        _set(prog, "u_tex", 0)
        _set(prog, "u_linear_target", False)
        tex.use(location=0)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self._render(self._panel_vao)
        self.ctx.disable(moderngl.BLEND)

    def draw_anaglyph(
        self,
        stereo: moderngl.Texture,
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int] | None = None,
    ) -> None:
        """Red-cyan anaglyph of a side-by-side stereo texture (left eye in its left half)."""
        framebuffer.use()
        framebuffer.viewport = viewport or (0, 0, *framebuffer.size)
        prog = self.programs["composite"]
        _set(prog, "u_mode", 0)
        _set(prog, "u_stereo", 0)
        stereo.use(location=0)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        self._render(self._composite_vao)

    def draw_vignette(
        self,
        strength: float,
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int] | None = None,
    ) -> None:
        """Darken the periphery by ``strength`` in [0, 1] (the comfort vignette while moving)."""
        if strength <= 0.0:
            return
        framebuffer.use()
        framebuffer.viewport = viewport or (0, 0, *framebuffer.size)
        prog = self.programs["composite"]
        _set(prog, "u_mode", 1)
        _set(prog, "u_strength", float(min(strength, 1.0)))
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        self.ctx.enable(moderngl.BLEND)
        self.ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        self._render(self._composite_vao)
        self.ctx.disable(moderngl.BLEND)

    def release(self) -> None:
        """Free every GL object this renderer made."""
        for obj in list(vars(self).values()):
            if isinstance(obj, moderngl.Buffer | moderngl.VertexArray | moderngl.Texture):
                obj.release()
        for tex in self._panel_textures.values():
            tex.release()
        for vaos in self._char_vaos:
            for vao, _ in vaos:
                vao.release()
        for buf in self._char_buffers:
            buf.release()
        for t in self._char_textures:
            if t is not None:
                t.release()
        self._shadow_fbo.release()
        for prog in self.programs.values():
            prog.release()


def _vertex_layout(prog: moderngl.Program) -> tuple[str, ...]:
    """The character vertex buffer's format for ``prog``: the attributes it reads, padding over the
    rest (a program's unused attributes are not in it, and moderngl binds only attributes that are)."""
    fmt, names = [], []
    fields = VERTEX_DTYPE.names or ()
    for code, name, field in zip(VERTEX_FORMAT.split(), VERTEX_ATTRIBUTES, fields, strict=True):
        if name in prog:
            fmt.append(code)
            names.append(name)
        else:
            fmt.append(f"{VERTEX_DTYPE.fields[field][0].itemsize}x")  # type: ignore[index]
    return (" ".join(fmt), *names)


def _write(prog: moderngl.Program, name: str, data: bytes) -> None:
    """Write raw bytes into a uniform (matrices and arrays, column-major float32)."""
    if name in prog:
        u = prog[name]
        assert isinstance(u, moderngl.Uniform), f"{name} is not a uniform"
        u.write(data)


def _fit(ctx: moderngl.Context, buf: moderngl.Buffer, data: bytes) -> tuple[moderngl.Buffer, bool]:
    """Write ``data`` into ``buf``, growing it (a new buffer: ``True``) when too small."""
    grew = len(data) > buf.size
    if grew:
        buf.release()
        buf = ctx.buffer(reserve=max(len(data), 2 * buf.size), dynamic=True)
    buf.write(data)
    return buf, grew
