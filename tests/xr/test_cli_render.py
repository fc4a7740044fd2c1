"""``pedvr run`` with files: PNG frames and an MP4 from the headless renderer; telemetry in the metrics."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from pedvr.cli import main


def test_frames_and_video_of_first_person_and_overhead(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    met = tmp_path / "m.json"
    code = main(
        [
            "run",
            "bidirectional_flow",  # outdoors: the sky shows (headon_corridor has a ceiling)
            "--duration",
            "0.5",
            "--frames",
            str(tmp_path / "f"),
            "--video",
            str(tmp_path / "v.mp4"),
            "--width",
            "64",
            "--height",
            "48",
            "--fps",
            "10",
            "--label",
            "C",
            "--metrics-json",
            str(met),
            "--out",
            str(tmp_path),
            "--quiet",
        ]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert out.startswith("backend: headless (rendering offscreen to --frames/--video)")
    fp = sorted((tmp_path / "f" / "first_person").glob("*.png"))
    ov = sorted((tmp_path / "f" / "overhead").glob("*.png"))
    assert len(fp) == len(ov) == 5  # t = 0, 0.1, ..., 0.4: frames at k/fps before the end (issue 24 item 11)
    first = np.asarray(Image.open(fp[0]))
    assert first.shape == (48, 64, 3) and first[1, -2, 2] > first[1, -2, 0]  # sky: bluish, top right
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    m = json.loads(met.read_text())
    assert m["frames"]["frames"] == 5 and m["frames"]["missed_frames"] == 0
    assert m["frames"]["render_ms_p50"] > 0 and m["frames"]["sim_ms_p50"] is not None
    assert "llvmpipe" in m["renderer"] or m["renderer"]
    assert m["steps"] == 45


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["run", "--backend", "desktop", "--frames", "x"],
            r"--frames/--video write files from the headless renderer",
        ),
        (["run", "--view", "fisheye"], r"argument --view: invalid choice: 'fisheye'"),
        (["run", "--label", "pedvr"], r"argument --label: invalid choice: 'pedvr'"),
    ],
)
def test_bad_render_flags_are_one_line(argv: list[str], message: str, capsys: pytest.CaptureFixture) -> None:
    import re

    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(message, err[0]), err


def test_plain_headless_run_needs_no_gl(tmp_path: Path) -> None:
    code = (
        "import sys\nfrom pedvr.cli import main\n"
        f"assert main(['run', 'headon_corridor', '--backend', 'headless', '--duration', '0.2', '--quiet', "
        f"'--out', {str(tmp_path)!r}]) == 0\n"
        "print('GL modules:', ','.join(m for m in ('moderngl', 'glfw', 'xr', 'glcontext') if m in sys.modules))\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip().splitlines()[-1] == "GL modules:"


def test_fps_is_honoured_and_the_video_plays_in_real_time(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """Issue 24 item 11: --fps 1 --duration 6 wrote 26 frames; --fps 2 --duration 2 made a 5 s video."""
    import imageio_ffmpeg

    base = ["run", "headon_corridor", "--width", "32", "--height", "24", "--quiet", "--out", str(tmp_path)]
    assert main([*base, "--duration", "6", "--fps", "1", "--frames", str(tmp_path / "f")]) == 0
    assert len(list((tmp_path / "f" / "first_person").glob("*.png"))) == 6  # t = 0, 1, ..., 5 s
    m = json.loads((tmp_path / "headon_corridor-seed3-pedvr.json").read_text())
    assert m["steps"] == 540 and m["frames"]["skipped_sim_s"] == 0  # the run still covers 6 s
    assert main([*base, "--duration", "2", "--fps", "2", "--video", str(tmp_path / "v.mp4")]) == 0
    frames, seconds = imageio_ffmpeg.count_frames_and_secs(str(tmp_path / "v.mp4"))
    assert frames == 4 and seconds == pytest.approx(2.0, abs=0.01)
