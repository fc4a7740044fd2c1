"""Antipodal-circle steering benchmark: pedvr's ORCA kernels against RVO2 (pyrvo).

Usage: ``python bench/steering.py [--agents 1000 4000] [--steps S] [--threads N] [--no-rvo2]``
"""

from __future__ import annotations

import argparse
import json

from pedvr.crowd.bench import run_steering_bench


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--agents", type=int, nargs="+", default=[1000, 4000])
    ap.add_argument("--steps", type=int, default=None,
                    help="default: until the crowd reaches the centre, plus 200")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--no-rvo2", action="store_true")
    args = ap.parse_args()
    for n in args.agents:
        res = run_steering_bench(n, vs_rvo2=not args.no_rvo2, steps=args.steps, seed=args.seed,
                                 threads=args.threads)
        print(json.dumps(res), flush=True)


if __name__ == "__main__":
    main()
