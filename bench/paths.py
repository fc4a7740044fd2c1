"""Path-query benchmark: ``NavMesh.find_path`` between random walkable points of shipped scenes.

Usage: ``python bench/paths.py [--scenes shopping_mall tradeshow] [--queries 300] [--seed 1]``.
One JSON line per scene: triangles, the mesh's build time (the second build, so numba's
compilation is not counted), queries, mean and p95 milliseconds per path (after one warm-up
query), and the median time to locate 100 random points (of 20 tries). A whole crowd plans when it spawns
and agents replan when pushed off their route, so this is on the step's critical path.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from pedvr.errors import NavigationError
from pedvr.scene.loader import load_any
from pedvr.scenes import resolve_scene
from pedvr.world import NavMesh


def bench_paths(scene: str, *, queries: int, seed: int, clearance: float = 0.25) -> dict[str, object]:
    sc = load_any(resolve_scene(scene), seed=None)
    NavMesh.build(sc.world, clearance=clearance).locate(np.zeros((1, 2)))  # compile or load the kernels
    t0 = time.perf_counter()
    mesh = NavMesh.build(sc.world, clearance=clearance)
    build_ms = (time.perf_counter() - t0) * 1e3
    (x0, y0), (x1, y1) = sc.world.bounds
    rng = np.random.default_rng(seed)
    pts = rng.uniform((x0, y0), (x1, y1), size=(2 * queries, 2))
    mesh.find_path(pts[0], pts[0])  # warm-up: compile or load the cached kernels
    ms = []
    for a, b in zip(pts[::2], pts[1::2], strict=True):
        t0 = time.perf_counter()
        try:
            mesh.find_path(a, b)
        except NavigationError:
            continue  # points in separate parts of the area
        ms.append((time.perf_counter() - t0) * 1e3)
    arr = np.asarray(ms)
    inside = np.array([mesh.random_point(rng) for _ in range(100)])
    mesh.locate(inside)
    locate = []
    for _ in range(20):
        t0 = time.perf_counter()
        mesh.locate(inside)
        locate.append(time.perf_counter() - t0)
    locate_ms = float(np.median(locate)) * 1e3
    return {"scene": scene, "triangles": int(mesh.tris.shape[0]), "build_ms": round(build_ms, 2),
            "queries": len(ms), "ms_mean": round(float(arr.mean()), 4),
            "ms_p95": round(float(np.percentile(arr, 95)), 4), "locate_100_ms": round(locate_ms, 4)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenes", nargs="+", default=["shopping_mall", "tradeshow", "shibuya_crossing"])
    ap.add_argument("--queries", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    for name in args.scenes:
        print(json.dumps(bench_paths(name, queries=args.queries, seed=args.seed)), flush=True)


if __name__ == "__main__":
    main()
