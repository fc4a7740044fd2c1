"""Crowd rendering benchmark: pose upload, draw submission and frame time, stereo, offscreen (EGL).

Usage: ``python bench/render.py [--agents 100 500] [--width 1280] [--height 720] [--frames 30] [--fovy 70]``
(the same figures as ``pedvr bench render --agents N --json``; a headset: ``--fovy 100`` at its pixels
per eye).
"""

from __future__ import annotations

import argparse
import json

from pedvr.render.bench import run_render_bench


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--agents", type=int, nargs="+", default=[100, 500])
    ap.add_argument("--width", type=int, default=1280, help="pixels per eye")
    ap.add_argument("--height", type=int, default=720)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--fovy", type=float, default=70.0, help="vertical field of view, degrees")
    args = ap.parse_args()
    for n in args.agents:
        print(
            json.dumps(run_render_bench(n, width=args.width, height=args.height, frames=args.frames,
                                        fovy=args.fovy)),
            flush=True,
        )


if __name__ == "__main__":
    main()
