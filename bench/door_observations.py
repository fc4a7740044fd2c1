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
  12 + 14): runs with a deadlock (``door_deadlocks``: since issue 26 also a queue wait of 20 s
  still going at the end) and runs with a stall (``door_stalls``: the door passed nobody, or
  stood free, for 20 s while someone waited), passages, and the 95th percentile wait.

* ``rush``: door_rush (issue 26): a single one-way door, 20 people from each side setting off
  over 20 s: how many are through after 90 s (of 40), when the last one passed, the 95th
  percentile wait at the door, ``door_deadlocks``; median and worst over the seeds, and each
  seed's count and last passage (``per_seed_through``, ``per_seed_last_s``: inf where someone
  was not through);
* ``single_flow``: the same measures for the realism benchmark's ``validation/door_single_flow``
  (people arriving from sources at 1 /s a side), plus the mean time of the 35th passage;
* ``double_flow``: the same for ``validation/door_double_flow`` (30 people at a double door; no 35th);
* ``double_queue``: door_double_queue (issue 26, §6.3): a queue of ten (and two the other way) at
  a double door: each leaf's share of the passages (the less used one's is the figure), when the
  last one passed; median and worst;
* ``pram``: a perambulator pusher (§4.6) at the single door of door_assist and at the double door
  of door_double (three walkers a side and the pram): its passages in 90 s, and the time of its
  first, per seed (issue 24 item 4, issue 26: "no carrier left behind");
* ``lone_pram``: a pram pusher alone on the pull side of door_assist's 1.3 m single door,
  door_same_side's 1.1 m one and door_double, from ten places 3 and 7 m from the door (issue 26,
  change 18: it turns round and backs through): how many of the runs get it through in 60 s, when
  (median and worst), the runs with an overlap over 1 cm (bodies, leaves or walls), the deepest
  wall overlap, and the runs where it gave the door up once or more.

* ``user_pram``: the same pram pusher from 5 m before the pull side of each of those doors, alone
  but for the participant (the scripted user, :class:`pedvr.etiquette.user.DoorUser`), who walks
  through the door from the pram's side (two routes) or toward it from the other side, setting
  off 4 to 30 m away (seven), or walks up to a place beside the pram's way and stands there (two):
  how many runs get the pram through in 60 s, when (median and worst), the deepest cut into the
  user, the runs with bodies overlapping over 1 cm, the deepest cut of a leaf into anyone, and
  the runs where it gave the door up once or more (issue 26: no carrier left behind, with the
  participant in it).

Passages and waits in ``rush``, ``double_queue`` and ``pram`` are measured from positions
(:class:`Crossings`), not from the etiquette's own events, so the figures mean the same before
and after a change to the etiquette.

    python bench/door_observations.py --seeds 10
    python bench/door_observations.py --seeds 6 --only rush double_queue pram
    python bench/door_observations.py --seeds 16 --first-seed 9 --only single_flow
    python bench/door_observations.py --seeds 3 --only lone_pram
    python bench/door_observations.py --seeds 2 --only user_pram
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


class Crossings:
    """Passages through each door measured from positions, every ``every`` steps: a body passes a
    door when the segment it moved along crosses the doorway (jamb to jamb) and it then stands
    :data:`CONFIRM` m on the other side (a body that steps back before that has not passed).
    ``waits[agent]``: seconds it stood (slower than 0.2 m/s) within :data:`NEAR` m of a door's
    middle before passing it."""

    CONFIRM = 0.4
    NEAR = 4.0

    def __init__(self, sim: Simulation) -> None:
        doors = sim.scene.world.doors
        self.p = np.array([d.span[0] for d in doors], np.float64).reshape(-1, 2)
        self.q = np.array([d.span[1] for d in doors], np.float64).reshape(-1, 2)
        self.c = 0.5 * (self.p + self.q)
        u = self.q - self.p
        u /= np.linalg.norm(u, axis=1)[:, None]
        self.u = u
        self.n = np.stack([-u[:, 1], u[:, 0]], axis=1)
        self.prev: dict[int, np.ndarray] = {}
        self.pending: dict[tuple[int, int], int] = {}  # (agent, door) -> the side it crossed from
        self.events: list[dict[str, Any]] = []  # {"t", "agent", "door", "side", "leaf_side", "waited_s"}
        self.waits: dict[int, float] = {}
        self.last_t = 0.0

    def update(self, sim: Simulation) -> None:
        c = sim.crowd
        dt = sim.t - self.last_t
        self.last_t = sim.t
        for r in range(len(c)):
            a = int(c.ids[r])
            pos = c.pos[r].copy()
            prev = self.prev.get(a, pos)
            self.prev[a] = pos
            rel = pos - self.c
            d_line = np.einsum("ij,ij->i", rel, self.n)
            lat = np.einsum("ij,ij->i", rel, self.u)
            if float(np.hypot(*c.vel[r])) < 0.2 and bool((np.hypot(*rel.T) < self.NEAR).any()):
                self.waits[a] = self.waits.get(a, 0.0) + dt
            for k in range(len(self.c)):
                if _seg_cross(prev, pos, self.p[k], self.q[k]):
                    side = 1 if float((prev - self.c[k]) @ self.n[k]) >= 0.0 else -1
                    if (a, k) in self.pending and self.pending[(a, k)] != side:
                        del self.pending[(a, k)]  # stepped back across: not a passage
                    else:
                        self.pending[(a, k)] = side
                side = self.pending.get((a, k))
                if side is not None and float(d_line[k]) * side < -self.CONFIRM:
                    del self.pending[(a, k)]
                    self.events.append({"t": round(sim.t, 3), "agent": a, "door": k, "side": side,
                                        "lat": round(float(lat[k]), 3), "user": bool(c.is_user[r]),
                                        "waited_s": round(self.waits.pop(a, 0.0), 3)})


def _seg_cross(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> bool:
    def orient(o: np.ndarray, x: np.ndarray, y: np.ndarray) -> float:
        return float((x[0] - o[0]) * (y[1] - o[1]) - (x[1] - o[1]) * (y[0] - o[0]))

    return (orient(a, b, p) * orient(a, b, q) <= 0.0 and orient(p, q, a) * orient(p, q, b) < 0.0)


def _run_crossings(scene: SceneConfig, seed: int, seconds: float) -> tuple[Crossings, dict[str, Any]]:
    sim = Simulation(scene, seed=seed)
    cr = Crossings(sim)
    while sim.t < seconds - 1e-9:
        for _ in range(3):
            sim.step()
        cr.update(sim)
    return cr, sim.summary()


def _med_worst(xs: list[float], worst: str) -> dict[str, float]:
    arr = np.asarray(xs, np.float64)
    return {"median": round(float(np.median(arr)), 3),
            "worst": round(float(arr.max() if worst == "max" else arr.min()), 3)}


def rush(seeds: list[int], seconds: float = 90.0, name: str = "door_rush",
         observation: str = "rush") -> dict[str, Any]:
    """door_rush (or validation/door_single_flow): 40 people through one single door (module
    docstring)."""
    scene = _scene(name)
    n = sum(sp.count + len(sp.positions) for sp in scene.spawns) + sum(so.max_count for so in scene.sources)
    through, last, p95, dead, rate, over, t35 = [], [], [], [], [], [], []
    for s in seeds:
        cr, summ = _run_crossings(scene, s, seconds)
        agents = [e for e in cr.events if not e["user"]]
        first = {}
        for e in agents:
            first.setdefault(e["agent"], e)
        through.append(len(first))
        t = sorted(e["t"] for e in first.values())
        last.append(t[-1] if len(first) == n else float("inf"))
        t35.append(t[34] if len(t) > 34 else float("inf"))
        rate.append(60.0 * (len(t) - 1) / max(t[-1] - t[0], 1e-9) if len(t) > 1 else 0.0)
        waits = [e["waited_s"] for e in first.values()]
        p95.append(float(np.percentile(waits, 95)) if waits else 0.0)
        dead.append(int(summ["door_deadlocks"]))
        over.append(int(summ["overlaps_over_1cm"]))
    return {"observation": observation, "scene": name, "agents": n, "seconds": seconds, "seeds": len(seeds),
            "through": _med_worst(through, "min"), "last_pass_s": _med_worst(last, "max"),
            "last_pass_s_mean": round(float(np.mean(last)), 2),
            "pass35_s_mean": round(float(np.mean(t35)), 2) if n >= 35 else None,
            "passages_per_min": _med_worst(rate, "min"), "wait_s_p95": _med_worst(p95, "max"),
            "door_deadlocks": _med_worst(dead, "max"), "overlaps_over_1cm": int(max(over)),
            "per_seed_through": through, "per_seed_last_s": last}


def double_queue(seeds: list[int], seconds: float = 60.0) -> dict[str, Any]:
    """door_double_queue: both leaves of a double door carry a queue (module docstring)."""
    scene = _scene("door_double_queue")
    n = sum(sp.count + len(sp.positions) for sp in scene.spawns)
    share, last, through = [], [], []
    for s in seeds:
        cr, _ = _run_crossings(scene, s, seconds)
        first = {}
        for e in cr.events:
            if not e["user"]:
                first.setdefault(e["agent"], e)
        through.append(len(first))
        west = [e for e in first.values() if e["side"] == 1]  # from the west, side +1 (the queue of ten)
        on = [sum(1 for e in west if e["lat"] < 0.0), sum(1 for e in west if e["lat"] >= 0.0)]
        share.append(min(on) / max(len(west), 1))
        t = [e["t"] for e in first.values()]
        last.append(max(t) if len(first) == n else float("inf"))
    return {"observation": "double_queue", "scene": "door_double_queue", "agents": n, "seeds": len(seeds),
            "queue_share_of_less_used_leaf": _med_worst(share, "min"), "last_pass_s": _med_worst(last, "max"),
            "through": _med_worst(through, "min")}


def _with_pram(name: str, counts: tuple[int, ...], at: tuple[float, float], state: str) -> SceneConfig:
    s = _scene(name, counts)
    if "pram" not in s.profiles:
        w = s.profiles["walker"]
        prof = dataclasses.replace(w, name="pram", radius=0.4, pref_speed=1.0, max_speed=1.4,
                                   carrying="perambulator", sex="female")
        s = dataclasses.replace(s, profiles={**s.profiles, "pram": prof})
    pram = dataclasses.replace(s.spawns[0], profile="pram", state=state, positions=(at,), count=0,
                               region=None)
    return dataclasses.replace(s, spawns=(pram, *s.spawns))


def pram(seeds: list[int], seconds: float = 90.0) -> dict[str, Any]:
    """A perambulator pusher at a single and a double door: its passages (module docstring)."""
    out: dict[str, Any] = {"observation": "pram", "seeds": len(seeds)}
    cases = {"single": _scene("door_assist"),  # its own pram among a box carrier, helpers and friends
             "double": _with_pram("door_double", (3, 3), (-5.0, -1.0), "east")}  # from its pull side
    for case, scene in cases.items():
        sim0 = Simulation(scene, seed=1)
        pram_ids = [int(sim0.crowd.ids[r]) for r in range(len(sim0.crowd))
                    if float(sim0.crowd.length[r]) > 0.0 and not bool(sim0.crowd.is_user[r])]
        passes, first = [], []
        for s in seeds:
            cr, _ = _run_crossings(scene, s, seconds)
            t = [e["t"] for e in cr.events if e["agent"] in pram_ids]
            passes.append(len(t))
            first.append(t[0] if t else float("inf"))
        out[case] = {"pram_passages": _med_worst(passes, "min"), "first_pass_s": _med_worst(first, "max"),
                     "per_seed_passages": passes,
                     "per_seed_first_pass_s": [round(t, 2) if t != float("inf") else None for t in first]}
    return out


LONE_STARTS = [(x, y) for y in (-3.0, -1.5, 0.0, 1.5, 3.0) for x in (-7.0, -3.0)]  # pull sides at x < 0


def lone_pram(seeds: list[int], seconds: float = 60.0) -> dict[str, Any]:
    """A pram pusher alone at a pull door, from :data:`LONE_STARTS` (module docstring)."""
    out: dict[str, Any] = {"observation": "lone_pram", "seeds": len(seeds), "starts": len(LONE_STARTS)}
    for name in ("door_assist", "door_same_side", "door_double"):
        base = _with_pram(name, (), (0.0, 0.0), "east")
        through, when, overlapping, gave_up, wall = 0, [], 0, 0, 0.0
        for s in seeds:
            for at in LONE_STARTS:
                pram_spawn = dataclasses.replace(base.spawns[0], positions=(at,))
                cr, summ = _run_crossings(dataclasses.replace(base, spawns=(pram_spawn,)), s, seconds)
                if cr.events:
                    through += 1
                    when.append(cr.events[0]["t"])
                overlapping += (summ["overlaps_over_1cm"] > 0 or summ["door_leaf_overlap_max_m"] > 0.01
                                or summ["wall_overlap_max_m"] > 0.01)
                gave_up += any(e["event"] == "give_up" for e in summ["door_events"])
                wall = max(wall, float(summ["wall_overlap_max_m"]))
        out[name] = {"runs": len(seeds) * len(LONE_STARTS), "through": through,
                     "first_pass_s": _med_worst(when or [float("inf")], "max"),
                     "runs_overlapping": overlapping, "wall_overlap_max_m": round(wall, 4),
                     "runs_giving_up": gave_up}
    return out


USER_ROUTES = [((-8.0, 0.0), (4.0, 0.0)), ((-9.0, -1.0), (4.0, -0.3))] + [
    ((x, y), (-8.0, y)) for x, y in ((4.0, 0.0), (8.0, 0.0), (12.0, 0.0), (16.0, 0.3), (22.0, 0.0),
                                  (26.0, 0.0), (30.0, 0.0))]
USER_STANDS = [(-3.0, 0.8), (-2.5, -2.5)]  # the participant walks up to here and stands


def user_pram(seeds: list[int], seconds: float = 60.0) -> dict[str, Any]:
    """A pram pusher alone but for the participant (module docstring)."""
    out: dict[str, Any] = {"observation": "user_pram", "seeds": len(seeds),
                           "routes": len(USER_ROUTES) + len(USER_STANDS)}
    for name in ("door_assist", "door_same_side", "door_double"):
        base = _with_pram(name, (), (-5.0, -1.0), "east")
        base = dataclasses.replace(base, spawns=base.spawns[:1])
        routes = USER_ROUTES + [((-8.0, y), (x, y)) for x, y in USER_STANDS]
        through, when, user_overlap, overlapping, gave_up, leaf = 0, [], 0.0, 0, 0, 0.0
        for s in seeds:
            for start, end in routes:
                user = dataclasses.replace(base.user, start=start, route=(end,))  # type: ignore[arg-type]
                cr, summ = _run_crossings(dataclasses.replace(base, user=user), s, seconds)
                t = [e["t"] for e in cr.events if not e["user"]]
                if t:
                    through += 1
                    when.append(t[0])
                user_overlap = max(user_overlap, float(summ["user_overlap_max_m"]))
                overlapping += summ["overlaps_over_1cm"] > 0
                leaf = max(leaf, float(summ["door_leaf_overlap_max_m"]))
                gave_up += any(e["event"] == "give_up" for e in summ["door_events"])
        out[name] = {"runs": len(seeds) * len(routes), "through": through,
                     "first_pass_s": _med_worst(when or [float("inf")], "max"),
                     "user_overlap_max_m": round(user_overlap, 4), "runs_overlapping": overlapping,
                     "door_leaf_overlap_max_m": round(leaf, 4), "runs_giving_up": gave_up}
    return out


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
    dead, stalled, passages, p95 = 0, 0, [], []
    for s in seeds:
        _, summ = _run(_scene("door_opposing", (west, east)), s, 60.0)
        dead += int(summ["door_deadlocks"]) > 0
        stalled += int(summ.get("door_stalls", summ["door_deadlocks"])) > 0
        passages.append(summ["door_passages"])
        p95.append(summ["door_wait_s_p95"])
    return {"observation": "deadlock", "per_side": [west, east], "seeds": len(seeds), "runs_deadlocked": dead,
            "runs_stalled": stalled, "passages_mean": float(np.mean(passages)),
            "wait_s_p95_mean": float(np.mean(p95))}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--only", nargs="*", default=None)
    ap.add_argument("--first-seed", type=int, default=1)
    a = ap.parse_args()
    seeds = list(range(a.first_seed, a.first_seed + a.seeds))
    jobs = {"interleave": lambda: interleave(seeds), "late_group": lambda: late_group(seeds),
            "hurried": lambda: hurried(seeds), "double": lambda: double(seeds),
            "revolving": lambda: revolving(seeds), "deadlock6": lambda: deadlock(seeds, 6, 6),
            "deadlock12": lambda: deadlock(seeds, 12, 14), "rush": lambda: rush(seeds),
            "single_flow": lambda: rush(seeds, name="validation/door_single_flow", observation="single_flow"),
            "double_flow": lambda: rush(seeds, name="validation/door_double_flow", observation="double_flow"),
            "double_queue": lambda: double_queue(seeds), "pram": lambda: pram(seeds),
            "lone_pram": lambda: lone_pram(seeds), "user_pram": lambda: user_pram(seeds)}
    unknown = sorted(set(a.only or ()) - set(jobs))
    if unknown:
        ap.error(f"--only {' '.join(unknown)}: no such observation; expected some of {', '.join(jobs)}")
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
