"""The paper's door observations (Huang & Terzopoulos §6) measured over many seeds in pedvr.

The tests (tests/etiquette/test_etiquette_sim.py) check each observation on a few seeds; this
measures them on ``--seeds`` seeds and prints one JSON line per observation:

* ``interleave``: door_opposing, the first 6 passages: fraction of seeds whose two groups
  alternate at least twice (§6.1, Fig. 12 bottom), and the mean number of alternations;
* ``late_group``: door_late_group: fraction of seeds whose first four passages are all the early
  group's (§6.1);
* ``hurried``: door_same_side with three calm (Rush 0) and three hurried (Rush 1) pedestrians:
  mean passing rank of each (Fig. 13);
* ``double``: door_double with one a side: each side's most used leaf and its share (§6.3; leaf 0
  is side +1's right-hand leaf, leaf 1 side -1's);
* ``revolving``: door_revolving: passages per minute from each side (§6.2);
* ``deadlock``: door_opposing with ``n`` pedestrians per side for 60 s (6 + 6 and the paper's
  12 + 14): runs with a deadlock (``door_deadlocks``), passages, and the 95th percentile wait.

    python bench/door_observations.py --seeds 10
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pedvr.scene.config import SceneConfig  # noqa: E402
from pedvr.scene.loader import load_scene  # noqa: E402
from pedvr.scenes import resolve_scene  # noqa: E402
from pedvr.sim import Simulation  # noqa: E402


def _scene(name: str, counts: tuple[int, ...] = ()) -> SceneConfig:
    s = load_scene(resolve_scene(name))
    if counts:
        s = dataclasses.replace(s, spawns=tuple(dataclasses.replace(sp, count=c)
                                                for sp, c in zip(s.spawns, counts, strict=True)))
    return s


def _run(scene: SceneConfig, seed: int, seconds: float) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    sim = Simulation(scene, seed=seed)
    sim.advance_to(seconds)
    assert sim.etiquette is not None
    return list(sim.etiquette.events), sim.summary()


def _passes(events: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [e for e in events if e["event"] == "pass" and not e.get("user")]


def interleave(seeds: list[int]) -> dict[str, Any]:
    ok, sw = 0, []
    for s in seeds:
        sides = [e["side"] for e in _passes(_run(_scene("door_opposing"), s, 35.0)[0])[:6]]
        n = sum(1 for a, b in zip(sides, sides[1:], strict=False) if a != b)
        sw.append(n)
        ok += n >= 2
    return {"observation": "interleave", "seeds": len(seeds), "fraction": ok / len(seeds),
            "alternations_mean": float(np.mean(sw))}


def late_group(seeds: list[int]) -> dict[str, Any]:
    ok = 0
    for s in seeds:
        sides = [e["side"] for e in _passes(_run(_scene("door_late_group"), s, 30.0)[0])[:4]]
        ok += len(sides) == 4 and len(set(sides)) == 1
    return {"observation": "late_group", "seeds": len(seeds), "fraction_early_first": ok / len(seeds)}


def hurried(seeds: list[int]) -> dict[str, Any]:
    base = _scene("door_same_side")
    w = base.profiles["walker"]
    sp = base.spawns[0]
    scene = dataclasses.replace(
        base, profiles={"calm": dataclasses.replace(w, rush=(0.0, 0.0)),
                        "hurried": dataclasses.replace(w, rush=(1.0, 1.0))},
        spawns=(dataclasses.replace(sp, profile="calm", count=3),
                dataclasses.replace(sp, profile="hurried", count=3)))
    ranks: dict[str, list[int]] = {"calm": [], "hurried": []}
    for s in seeds:
        order = list(dict.fromkeys(e["agent"] for e in _passes(_run(scene, s, 32.0)[0])))
        for rank, a in enumerate(order):
            ranks["hurried" if a >= 4 else "calm"].append(rank)
    return {"observation": "hurried", "seeds": len(seeds), "rank_mean_calm": float(np.mean(ranks["calm"])),
            "rank_mean_hurried": float(np.mean(ranks["hurried"]))}


def double(seeds: list[int]) -> dict[str, Any]:
    by_side: dict[int, list[int]] = {1: [], -1: []}
    for s in seeds:
        for e in _passes(_run(_scene("door_double", (1, 1)), s, 40.0)[0]):
            by_side[e["side"]].append(e["leaf"])
    out: dict[str, Any] = {"observation": "double", "seeds": len(seeds)}
    for side, leaves in by_side.items():
        fav = max(set(leaves), key=leaves.count)
        out[f"side{side:+d}_favourite_leaf"] = fav
        out[f"side{side:+d}_favourite_fraction"] = round(leaves.count(fav) / len(leaves), 3)
    return out


def revolving(seeds: list[int]) -> dict[str, Any]:
    rates = {1: [], -1: []}  # type: ignore[var-annotated]
    for s in seeds:
        p = _passes(_run(_scene("door_revolving"), s, 60.0)[0])
        for side in (1, -1):
            rates[side].append(sum(1 for e in p if e["side"] == side))
    return {"observation": "revolving", "seeds": len(seeds),
            "passages_per_min_side+1": float(np.mean(rates[1])),
            "passages_per_min_side-1": float(np.mean(rates[-1]))}


def deadlock(seeds: list[int], west: int, east: int) -> dict[str, Any]:
    dead, passages, p95 = 0, [], []
    for s in seeds:
        _, summ = _run(_scene("door_opposing", (west, east)), s, 60.0)
        dead += int(summ["door_deadlocks"]) > 0
        passages.append(summ["door_passages"])
        p95.append(summ["door_wait_s_p95"])
    return {"observation": "deadlock", "per_side": [west, east], "seeds": len(seeds), "runs_deadlocked": dead,
            "passages_mean": float(np.mean(passages)), "wait_s_p95_mean": float(np.mean(p95))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--only", nargs="*", default=None)
    a = ap.parse_args()
    seeds = list(range(1, a.seeds + 1))
    jobs = {"interleave": lambda: interleave(seeds), "late_group": lambda: late_group(seeds),
            "hurried": lambda: hurried(seeds), "double": lambda: double(seeds),
            "revolving": lambda: revolving(seeds), "deadlock6": lambda: deadlock(seeds, 6, 6),
            "deadlock12": lambda: deadlock(seeds, 12, 14)}
    for name, job in jobs.items():
        if a.only and name not in a.only:
            continue
        t0 = time.perf_counter()
        r = job()
        r["wall_s"] = round(time.perf_counter() - t0, 1)
        print(json.dumps(r), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
