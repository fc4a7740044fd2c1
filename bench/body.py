"""Body-layer benchmark: ms per step for the whole body layer beside the steering step.

Usage: ``python bench/body.py [--agents 100 1000] [--steps S] [--json]``
(the CLI's ``pedvr bench body --agents N --json`` runs the same function).
"""

from __future__ import annotations

import argparse
import json

from pedvr.body.bench import run_body_bench


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--agents", type=int, nargs="+", default=[100, 1000])
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true", help="one JSON object per line")
    args = ap.parse_args()
    for n in args.agents:
        res = run_body_bench(n, steps=args.steps, seed=args.seed)
        if args.json:
            print(json.dumps(res), flush=True)
        else:
            print(f"{n:5d} agents: body {res['body_ms_mean']:.3f} ms/step (p95 {res['body_ms_p95']:.3f}), "
                  f"steering {res['steering_ms_mean']:.3f} ms/step, bone matrices "
                  f"{res['joint_matrices_ms_mean']:.3f} ms", flush=True)


if __name__ == "__main__":
    main()
