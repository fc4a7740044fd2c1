"""How long numba takes to compile each kernel a scene's set-up and first step use (issue 27 goal 2).

Run it with an empty numba cache, or it measures the cache's loads, not compiles::

    XDG_CACHE_HOME=$(mktemp -d) python bench/compile_times.py [SCENE] [--top N]

One process, no second one (:mod:`pedvr.warmup` is not started). It prints one JSON object: the
set-up's and the first step's seconds, and the ``--top`` kernels that took longest to compile,
each with its seconds (numba's ``numba:compile`` events, a callee's time counted in its caller's
too) and whether a pedvr kernel called it. This found stop 50's cause: the pose graph's
``_pose_span`` took 212 s of a 313 s compile of the default scene.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numba.core.event as numba_event


class _Times(numba_event.Listener):  # type: ignore[misc]
    def __init__(self) -> None:
        self.stack: list[float] = []
        self.seconds: dict[str, float] = {}
        self.nested: dict[str, bool] = {}

    def on_start(self, event: Any) -> None:
        self.stack.append(time.perf_counter())

    def on_end(self, event: Any) -> None:
        took = time.perf_counter() - self.stack.pop()
        disp = event.data.get("dispatcher") if isinstance(event.data, dict) else None
        func = getattr(disp, "py_func", None)
        if func is None or not func.__module__.startswith("pedvr."):
            return  # numba's own overloads: part of the pedvr kernel that asked for them
        name = f"{func.__module__}.{func.__qualname__}"
        self.seconds[name] = self.seconds.get(name, 0.0) + took
        self.nested[name] = self.nested.get(name, True) and bool(self.stack)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene", nargs="?", default="antipodal_circle")
    ap.add_argument("--condition", default="pedvr+g")
    ap.add_argument("--top", type=int, default=12)
    args = ap.parse_args()

    from pedvr.scene.loader import load_any
    from pedvr.scenes import resolve_scene
    from pedvr.sim import Simulation

    scene = load_any(resolve_scene(args.scene), seed=None)
    times = _Times()
    with numba_event.install_listener("numba:compile", times):
        t0 = time.perf_counter()
        sim = Simulation(scene, condition=args.condition)
        t1 = time.perf_counter()
        sim.step()
        t2 = time.perf_counter()
    top = sorted(times.seconds.items(), key=lambda kv: -kv[1])[:args.top]
    print(json.dumps({
        "scene": args.scene, "condition": args.condition, "set_up_s": round(t1 - t0, 1),
        "first_step_s": round(t2 - t1, 1), "kernels_compiled": len(times.seconds),
        "longest": [{"kernel": k, "s": round(v, 1), "called_by_a_kernel": times.nested[k]} for k, v in top],
    }, indent=1))


if __name__ == "__main__":
    main()
