"""The offscreen presenter of headless runs: EGL rendering to PNG files and an MP4 video.

Frames are taken at fixed simulated times ``k / fps`` (``fps`` default 30) for
``k / fps`` < the run's duration, not at wall-clock times, so the same seed
gives the same images, ``--fps 1 --duration 6`` gives 6 frames, and the video
(at ``fps``) plays in real time (issue 24 item 11: the frame loop's stall
guard used to skip simulated time between frames more than 0.25 s apart). Each frame is the first
person view (``view``: mono, side-by-side or anaglyph; the scripted user's
eyes) and the overhead debug view; ``--frames DIR`` writes
``DIR/first_person/000000.png`` and ``DIR/overhead/000000.png``, ``--video
FILE`` one MP4 with the two views side by side (H.264 through
imageio-ffmpeg's bundled ffmpeg, pip-installable).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pedvr.errors import BackendUnavailableError, UsageError
from pedvr.render.renderer import OffscreenTarget, Renderer, create_offscreen_context
from pedvr.render.snapshot import Snapshot
from pedvr.render.text import Hud
from pedvr.render.views import VIEW_MODES, ViewComposer
from pedvr.xr.loop import FrameTiming

if TYPE_CHECKING:
    from pedvr.sim import Simulation


class VideoWriter:
    """H.264 MP4 through imageio-ffmpeg (its ffmpeg binary ships in the wheel)."""

    def __init__(self, path: Path, *, size: tuple[int, int], fps: float) -> None:
        try:
            import imageio_ffmpeg
        except ImportError:
            raise BackendUnavailableError(
                "cannot write --video: imageio-ffmpeg is not installed (pip install imageio-ffmpeg)"
            ) from None
        if size[0] % 2 or size[1] % 2:
            raise UsageError(
                f"video size {size[0]}x{size[1]}: width and height must be even (H.264, yuv420p)"
            )
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._gen = imageio_ffmpeg.write_frames(
            str(path),
            size,
            fps=fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            quality=7,
            macro_block_size=2,
            ffmpeg_log_level="error",
        )
        self._gen.send(None)
        self.frames = 0

    def write(self, rgb: np.ndarray) -> None:
        self._gen.send(np.ascontiguousarray(rgb, dtype=np.uint8).tobytes())
        self.frames += 1

    def close(self) -> None:
        self._gen.close()


class OffscreenPresenter:
    """Renders each frame offscreen and writes it to files. Keyword-only options as the CLI's."""

    name = "headless"

    def __init__(
        self,
        sim: Simulation,
        *,
        frames_dir: Path | None,
        video: Path | None,
        view: str = "mono",
        width: int = 640,
        height: int = 360,
        fps: float = 30.0,
        hud_label: str | None = None,
    ) -> None:
        if view not in VIEW_MODES:
            raise UsageError(f"--view {view!r}: expected one of {', '.join(VIEW_MODES)}")
        if fps <= 0:
            raise UsageError(f"--fps {fps}: must be > 0")
        self.sim = sim
        self.view = view
        self.size = (width, height)
        self.fps = fps
        self.frames_dir = frames_dir
        self.ctx = create_offscreen_context()
        self.renderer = Renderer.for_scene(self.ctx, sim.scene)
        self.composer = ViewComposer(self.renderer)
        self.first = OffscreenTarget(self.ctx, self.size, samples=4)  # multisampled (issue 16)
        self.over = OffscreenTarget(self.ctx, self.size)
        self.hud = Hud(label=hud_label)
        self.video = VideoWriter(video, size=(2 * width, height), fps=fps) if video is not None else None
        if frames_dir is not None:
            for sub in ("first_person", "overhead"):
                (frames_dir / sub).mkdir(parents=True, exist_ok=True)
        self.index = 0
        self._closed = False

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def renderer_name(self) -> str:
        return str(self.ctx.info.get("GL_RENDERER", "unknown"))

    def wait_frame(self) -> FrameTiming:
        return FrameTiming(display_time=self.index / self.fps, period=1.0 / self.fps)

    def draw(self, sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``sim``'s first-person and overhead views offscreen; return them (RGB, top row first)."""
        snap = Snapshot.from_sim(sim)
        r = self.renderer
        r.begin_frame()
        r.hide_user = True
        r.update(snap)
        u = snap.user_row
        if u is None:
            (x0, y0), (x1, y1) = sim.scene.world.bounds
            pos, heading = np.array([x0, (y0 + y1) / 2]), 0.0
        else:
            pos, heading = snap.pos[u], float(snap.heading[u])
        self.hud.fps, self.hud.frame_ms = self.fps, 1e3 / self.fps
        self.composer.draw(
            self.view,
            framebuffer=self.first.fbo,
            viewport=(0, 0, *self.size),
            pos=pos,
            heading=heading,
            hud=self.hud if self.view != "overhead" else None,
        )
        r.draw_overhead(framebuffer=self.over.fbo, snap=snap)
        return self.first.read(), self.over.read()

    def render(self, sim: Simulation) -> None:
        from PIL import Image

        first, over = self.draw(sim)
        if self.frames_dir is not None:
            Image.fromarray(first).save(self.frames_dir / "first_person" / f"{self.index:06d}.png")
            Image.fromarray(over).save(self.frames_dir / "overhead" / f"{self.index:06d}.png")
        if self.video is not None:
            self.video.write(np.concatenate([first, over], axis=1))

    def end_frame(self) -> None:
        self.index += 1

    def close(self) -> None:
        if self.video is not None:
            self.video.close()
        self.composer.release()
        self.renderer.release()
        self.first.release()
        self.over.release()
        self.ctx.release()
        self._closed = True
