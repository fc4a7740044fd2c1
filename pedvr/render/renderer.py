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
   for eye ``k % 2``; a clip plane cuts each half): the crowd is one draw call
   whatever the number of agents or eyes.
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
from pedvr.render.environment import (
    ENV_DTYPE,
    door_leaf_vertices,
    environment_mesh,
    place_leaves,
    sphere_vertices,
)
from pedvr.render.figures import BODY, agent_looks, default_dims, skeleton_mesh, standing_bones
from pedvr.render.math3d import EyeView, overhead_transform
from pedvr.render.overhead import BACKGROUND, disc_fan, frame_geometry, static_triangles
from pedvr.render.shaders import SHADER_DIR, compile_program
from pedvr.render.shaders import set_uniform as _set
from pedvr.render.snapshot import SPHERE_HEIGHT, Snapshot
from pedvr.scene.config import WorldConfig

GL_CLIP_DISTANCE0 = 0x3000
GL_FRAMEBUFFER_SRGB = 0x8DB9
SKY_LINEAR = (0.62, 0.74, 0.88)  # the shaders' SKY: the clear colour matches the fog


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


class OffscreenTarget:
    """Colour (RGBA8) + depth framebuffer of ``size`` ``(width, height)``; :meth:`read`: top row first."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], *, samples: int = 0) -> None:
        self.size = size
        self.color = ctx.texture(size, 4, samples=samples)
        self.depth = ctx.depth_renderbuffer(size, samples=samples)
        self.fbo = ctx.framebuffer(color_attachments=[self.color], depth_attachment=self.depth)

    def read(self, *, components: int = 3) -> np.ndarray:
        data = self.fbo.read(components=components, alignment=1)
        img = np.frombuffer(data, dtype=np.uint8).reshape(self.size[1], self.size[0], components)
        return img[::-1].copy()

    def release(self) -> None:
        self.fbo.release()
        self.color.release()
        self.depth.release()


class Renderer:
    """Draws one world and its crowd. Keyword-only options:

    ``shader_dir``: where the GLSL files are. ``hide_user``: do not draw the
    user's own body (first person, issue 4).
    """

    def __init__(
        self,
        ctx: moderngl.Context,
        *,
        world: WorldConfig,
        shader_dir: Path = SHADER_DIR,
        hide_user: bool = True,
    ) -> None:
        self.ctx = ctx
        self.world = world
        self.skeleton = BODY
        self.hide_user = hide_user
        self.stats = FrameStats()
        self._n = 0
        self._capacity = 0
        self._sphere: np.ndarray | None = None
        self._sphere_radius = 0.25
        self._snap: Snapshot | None = None

        names = ("crowd", "environment", "shadow", "overlay", "discs", "panel", "composite")
        self.programs = {n: compile_program(ctx, f"{n}.glsl", shader_dir=shader_dir) for n in names}
        p = self.programs

        mesh = skeleton_mesh(self.skeleton)
        self._crowd_vbo = ctx.buffer(mesh.tobytes())
        self._crowd_vao = ctx.vertex_array(
            p["crowd"], [(self._crowd_vbo, "3f 3f 1i 1i", "in_pos", "in_normal", "in_bone", "in_slot")]
        )
        self.crowd_vertices = len(mesh)

        env = environment_mesh(world)
        self._floor_vbo = ctx.buffer(env.floor.tobytes())
        self._solid_vbo = ctx.buffer(env.solids.tobytes())
        fmt = ("3f 3f 3f", "in_pos", "in_normal", "in_color")
        self._floor_vao = ctx.vertex_array(p["environment"], [(self._floor_vbo, *fmt)])
        self._solid_vao = ctx.vertex_array(p["environment"], [(self._solid_vbo, *fmt)])
        leaves = DoorLeaves.of_world(world)
        self._closed_doors = leaves.pose()
        self._leaf_local = [door_leaf_vertices(float(w), float(h))
                            for w, h in zip(leaves.length, leaves.height, strict=True)]
        placed = place_leaves(self._leaf_local, self._closed_doors)
        self._leaf_count = len(placed)
        self._leaf_vbo = ctx.buffer(placed.tobytes() if len(placed) else b"\0" * ENV_DTYPE.itemsize,
                                    dynamic=True)
        self._leaf_vao = ctx.vertex_array(p["environment"], [(self._leaf_vbo, *fmt)])
        sphere = sphere_vertices()
        self._sphere_vbo = ctx.buffer(sphere.tobytes())
        self._sphere_vao = ctx.vertex_array(p["environment"], [(self._sphere_vbo, *fmt)])

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
        if cap > limit or 4 * self.skeleton.joints > limit:
            raise BackendUnavailableError(f"{n} agents: more than this GPU's texture height {limit} allows")
        for name in ("_bones", "_palette", "_discs"):
            old = getattr(self, name, None)
            if old is not None:
                old.release()
        self._bones = self.ctx.texture((4 * self.skeleton.joints, cap), 4, dtype="f4")
        self._palette = self.ctx.texture((4, cap), 4, dtype="f4")
        self._discs = self.ctx.texture((1, cap), 4, dtype="f4")
        for tex in (self._bones, self._palette, self._discs):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._capacity = cap

    def begin_frame(self) -> None:
        """Reset the per-frame draw-call count."""
        self.stats.draw_calls = 0

    def update(self, snap: Snapshot) -> None:
        """Upload the crowd of ``snap``: its body poses (``snap.bones``), looks and shadow discs."""
        t0 = time.perf_counter()
        show = ~snap.is_user if self.hide_user else np.ones(len(snap), np.bool_)
        rows = np.flatnonzero(show)
        n = int(rows.size)
        palette, _ = agent_looks(snap.ids)
        dims = default_dims(snap.ids) if snap.dims is None else np.asarray(snap.dims, np.float64)
        if snap.bones is None:
            world = standing_bones(snap.pos[rows], snap.heading[rows], dims[rows])
        else:
            bones = np.asarray(snap.bones)
            if bones.shape != (len(snap), self.skeleton.joints, 4, 4):
                raise ValueError(
                    f"bones shape {bones.shape}: expected ({len(snap)}, {self.skeleton.joints}, 4, 4)"
                )
            world = bones[rows].astype(np.float32)  # a copy: the caller's array is not touched
        # Segments are sized for the reference adult: scale each agent's joint frames by its body scale.
        world[:, :, :3, :3] *= dims[rows, 3].astype(np.float32)[:, None, None, None]
        t1 = time.perf_counter()
        self._ensure_capacity(max(n, 1))
        if n:
            # Column-major: texel 4j + k of row i is column k of agent i's joint j.
            cols = np.ascontiguousarray(world.transpose(0, 1, 3, 2), dtype=np.float32)
            self._bones.write(cols.tobytes(), viewport=(0, 0, 4 * self.skeleton.joints, n))
            pal = np.zeros((n, 4, 4), np.float32)
            pal[:, :, :3] = palette[rows]
            self._palette.write(pal.tobytes(), viewport=(0, 0, 4, n))
            discs = np.zeros((n, 4), np.float32)
            discs[:, :2], discs[:, 2], discs[:, 3] = snap.pos[rows], snap.radius[rows], 1.0
            self._discs.write(discs.tobytes(), viewport=(0, 0, 1, n))
        if self._leaf_count:
            pose = self._closed_doors if snap.doors is None else np.asarray(snap.doors, np.float64)
            if pose.shape != self._closed_doors.shape:
                raise ValueError(f"doors shape {pose.shape}: expected {self._closed_doors.shape}")
            self._leaf_vbo.write(place_leaves(self._leaf_local, pose).tobytes())
        self._n = n
        self._sphere = None if snap.sphere is None else np.asarray(snap.sphere, dtype=np.float64)
        self._sphere_radius = min(0.25, 0.6 * snap.sphere_radius)
        self._snap = snap
        t2 = time.perf_counter()
        self.stats.pose_ms = (t1 - t0) * 1e3
        self.stats.upload_ms = (t2 - t1) * 1e3
        self.stats.agents_drawn = n

    # -- 3D views ------------------------------------------------------------------------------

    def _render(self, vao: moderngl.VertexArray, **kw: object) -> None:
        vao.render(**kw)  # type: ignore[arg-type]
        self.stats.draw_calls += 1

    def _common(self, prog: moderngl.Program, eyes: Sequence[EyeView], srgb_encode: bool) -> None:
        vp = np.zeros((2, 4, 4), np.float32)
        pos = np.zeros((2, 3), np.float32)
        for k in range(2):
            e = eyes[min(k, len(eyes) - 1)]
            vp[k] = e.view_projection.T  # GL column-major
            pos[k] = e.position
        _write(prog, "u_view_proj", vp.tobytes())
        _write(prog, "u_eye_pos", pos.tobytes())
        _set(prog, "u_eyes", len(eyes))
        _set(prog, "u_srgb_encode", srgb_encode)

    def draw_scene(
        self,
        eyes: Sequence[EyeView],
        *,
        framebuffer: moderngl.Framebuffer,
        viewport: tuple[int, int, int, int] | None = None,
        srgb_encode: bool = True,
        clear: bool = True,
    ) -> None:
        """Draw the 3D scene for one eye, or two eyes side by side in one pass, into ``viewport``."""
        if len(eyes) not in (1, 2):
            raise ValueError(f"{len(eyes)} eyes: expected 1 or 2")
        ctx = self.ctx
        framebuffer.use()
        vp = viewport or (0, 0, *framebuffer.size)
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
        k = len(eyes)
        env = self.programs["environment"]
        self._common(env, eyes, srgb_encode)
        _write(env, "u_model", np.eye(4, dtype=np.float32).tobytes())
        _set(env, "u_emissive", (0.0, 0.0, 0.0))
        _set(env, "u_pattern", 1)
        self._render(self._floor_vao, instances=k)
        _set(env, "u_pattern", 0)
        self._render(self._solid_vao, instances=k)
        if self._leaf_count:
            self._render(self._leaf_vao, instances=k)
        if self._sphere is not None:
            m = np.eye(4, dtype=np.float32)
            m[:3, :3] *= 2 * self._sphere_radius
            m[:3, 3] = (self._sphere[0], SPHERE_HEIGHT, self._sphere[1])
            _write(env, "u_model", m.T.tobytes())
            _set(env, "u_emissive", (0.25, 0.01, 0.0))
            self._render(self._sphere_vao, instances=k)
        if self._n:
            crowd = self.programs["crowd"]
            self._common(crowd, eyes, srgb_encode)
            _set(crowd, "u_bones", 0)
            _set(crowd, "u_palette", 1)
            self._bones.use(location=0)
            self._palette.use(location=1)
            self._render(self._crowd_vao, instances=self._n * k)
            shadow = self.programs["shadow"]
            self._common(shadow, eyes, srgb_encode)
            _set(shadow, "u_discs", 2)
            self._discs.use(location=2)
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
            framebuffer.depth_mask = False
            self._render(self._shadow_vao, instances=self._n * k)
            framebuffer.depth_mask = True
            ctx.disable(moderngl.BLEND)
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
        for prog in self.programs.values():
            prog.release()


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
