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
    assert len(fp) == len(ov) == 6  # t = 0, 0.1, ..., 0.5
    first = np.asarray(Image.open(fp[0]))
    assert first.shape == (48, 64, 3) and first[1, -2, 2] > first[1, -2, 0]  # sky: bluish, top right
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    m = json.loads(met.read_text())
    assert m["frames"]["frames"] == 6 and m["frames"]["missed_frames"] == 0
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
