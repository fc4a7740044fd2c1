"""``pedvr bench render``: CPU cost of posing, uploading and submitting the crowd, and frame time.

Stereo at ``width × height`` per eye (both eyes in one side-by-side pass),
offscreen through EGL, with a vertical field of view of ``fovy`` degrees
(the desktop's 70° by default; a headset's is wider, about 90–110°, so at
the same pixels it has fewer per degree and draws more agents at coarser
levels of detail). Agents walk on a grid in front of the user, posed by the
body layer (its cost is the simulation's and is not counted here); those
wholly outside both eyes' views are not drawn in them (``agents_in_view``).
Per frame: the skinning matrices, looks and blinks (``pose_ms``), the texture
uploads (``upload_ms``), the draw submission (``submit_ms``, CPU time to issue
the draw calls, the shadow map's included), and the whole frame including
``glFinish`` (``frame_ms``). ``cpu_ms`` is the three together (the goal, issue
16: at most 1 ms at 500 agents). ``draw_calls`` is per frame and must not grow
with the number of agents (in the view and in the shadow map one per
character, level of detail and piece of the mesh someone wears, plus the
world's); ``vertices_per_frame`` counts the crowd's vertices submitted (both
eyes and the shadow map: the vertex shader's runs), ``lod_agents`` how many
agents each level drew in the view (last frame; agents out of both eyes'
views are not drawn), beside ``vertices_if_all_lod0`` (every agent's whole
finest mesh, all pieces, in all three). Absolute frame times mean something only on a GPU;
on Mesa llvmpipe (``renderer`` names it) they measure the software rasteriser.
"""

from __future__ import annotations

import math
import time

import numpy as np

from pedvr.body import FullBody
from pedvr.crowd.state import CrowdState
from pedvr.render.math3d import desktop_stereo_eyes
from pedvr.render.renderer import OffscreenTarget, Renderer, create_offscreen_context, gl_renderer_name
from pedvr.render.snapshot import Snapshot
from pedvr.scene.config import WorldConfig


class _Crowd:
    """Agents on a grid, walking back and forth, posed by a real :class:`~pedvr.body.FullBody`."""

    def __init__(self, agents: int) -> None:
        side = math.ceil(math.sqrt(agents))
        k = np.arange(agents)
        self.base = np.stack([2.0 + (k // side) * 0.9, (k % side - side / 2) * 0.9], axis=1)
        self.heading = np.where(k % 2 == 0, 0.0, math.pi) + 0.1 * np.sin(k)
        self.k = k
        ids = k.astype(np.int64)
        self.body = FullBody(rng=np.random.default_rng(0))
        self.body.append(agents, ids=ids, pos=self.base, heading=self.heading, is_user=False)
        for i in range(0, agents, 3):
            self.body.gaze_at(int(i), (0.0, 1.65, 0.0))
        n = agents
        self.crowd = CrowdState(
            ids=ids, pos=self.base.copy(), vel=np.zeros((n, 2)), pref_vel=np.zeros((n, 2)),
            heading=self.heading.copy(), pref_heading=self.heading.copy(), radius=np.full(n, 0.25),
            pref_speed=np.full(n, 1.3), max_speed=np.full(n, 1.6), responsibility=np.full(n, 0.5),
            is_user=np.zeros(n, np.bool_), limits=np.zeros((n, 6)),
        )

    def step(self, t: float, dt: float) -> Snapshot:
        """Advance the bodies to ``t`` (the body's cost is the simulation's, not timed here)."""
        fwd = np.stack([np.cos(self.heading), np.sin(self.heading)], axis=1)
        pos = self.base + 0.3 * np.sin(t + self.k)[:, None] * fwd
        vel = (pos - self.crowd.pos) / dt
        self.body.compose(self.crowd, pos, self.heading, dt=dt, t=t, coupled=True)
        self.crowd.pos, self.crowd.vel = pos, vel
        return Snapshot.of_agents(
            pos=pos, heading=self.heading, vel=vel, ids=self.crowd.ids, bones=self.body.joint_matrices(),
            dims=self.body.state.dims, t=t,
        )


def run_render_bench(
    agents: int, *, width: int = 1280, height: int = 720, frames: int = 30, warmup: int = 3,
    fovy: float = 70.0,
) -> dict[str, object]:
    """Figures for ``agents`` agents; see the module docstring for the keys."""
    if agents <= 0 or frames <= 0 or width <= 0 or height <= 0:
        raise ValueError("agents, frames, width and height must be > 0")
    if not 0.0 < fovy < 180.0:
        raise ValueError(f"fovy = {fovy}: must be between 0 and 180 degrees")
    ctx = create_offscreen_context()
    side = math.ceil(math.sqrt(agents)) * 0.9 + 4.0
    world = WorldConfig(bounds=((-2.0, -side), (side + 4.0, side)))
    r = Renderer(ctx, world=world)
    target = OffscreenTarget(ctx, (2 * width, height))
    eyes = desktop_stereo_eyes(pos=np.zeros(2), heading=0.0, aspect=width / height, fovy=math.radians(fovy))
    pose, upload, submit, frame, calls, verts = [], [], [], [], [], []
    crowd = _Crowd(agents)
    for i in range(warmup + frames):
        snap = crowd.step((i + 1) / 90.0, 1.0 / 90.0)
        t0 = time.perf_counter()
        r.begin_frame()
        r.update(snap)
        t1 = time.perf_counter()
        r.draw_scene(list(eyes), framebuffer=target.fbo)
        t2 = time.perf_counter()
        ctx.finish()
        t3 = time.perf_counter()
        if i >= warmup:
            pose.append(r.stats.pose_ms)
            upload.append(r.stats.upload_ms)
            submit.append((t2 - t1) * 1e3)
            frame.append((t3 - t0) * 1e3)
            calls.append(r.stats.draw_calls)
            verts.append(r.stats.vertices)
    name = gl_renderer_name(ctx)
    lod = list(r.stats.lod_agents)
    lod0 = r.characters[0].vertex_counts[0]
    target.release()
    r.release()
    ctx.release()

    def p(xs: list[float], q: float) -> float:
        return round(float(np.percentile(xs, q)), 3)

    return {
        "agents": agents,
        "width": width,
        "height": height,
        "fovy": fovy,
        "eyes": 2,
        "frames": frames,
        "pose_ms_p50": p(pose, 50),
        "upload_ms_p50": p(upload, 50),
        "submit_ms_p50": p(submit, 50),
        "cpu_ms_p50": p([a + b + c for a, b, c in zip(pose, upload, submit, strict=True)], 50),
        "frame_ms_p50": p(frame, 50),
        "frame_ms_p95": p(frame, 95),
        "draw_calls_per_frame": max(calls),
        "draw_calls_constant": min(calls) == max(calls),
        "vertices_per_frame": int(np.median(verts)),
        "vertices_if_all_lod0": 3 * lod0 * agents,  # two eyes and the shadow map
        "lod_agents": lod,
        "agents_in_view": int(sum(lod)),
        "mesh_vertices_per_lod": list(r.characters[0].vertex_counts),
        "renderer": name,
    }
