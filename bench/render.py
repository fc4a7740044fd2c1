"""Crowd rendering benchmark: pose upload, draw submission and frame time, stereo, offscreen (EGL).

Usage: ``python bench/render.py [--agents 100 500] [--width 1280] [--height 720] [--frames 30]``
(the same figures as ``pedvr bench render --agents N --json``).
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
    args = ap.parse_args()
    for n in args.agents:
        print(
            json.dumps(run_render_bench(n, width=args.width, height=args.height, frames=args.frames)),
            flush=True,
        )


if __name__ == "__main__":
    main()
