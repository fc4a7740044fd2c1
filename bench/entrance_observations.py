"""How people pass the 0.7 m entrance of the Jülich corridor, real against pedvr (issue 26).

The realism benchmark gives the flow; this looks at what sets it. For the real recordings
(``$PEDVR_REAL_DATA/uni-directional/uo-*.txt``, PedPy's demo data) it prints each file's
tangential acceleration percentiles, the speed smoothed over 0.5 s and the first and last 1 s of
every track left out (the smoothing's edges put 2-3 m/s² there that nobody walked). For
uo-070 and ``scenes/validation/uo_070`` run in pedvr it prints, at the line y = 7.5 m (0.5 m
into the corridor past the entrance, inside the real cameras' view), how many crossed, the
median speed there and the gaps between crossings; for pedvr also how fast people walk within
0.6 m before the entrance and the share of those steps in ORCA's dense case, and its
acceleration percentiles measured as the real ones are (tracks sampled at 16 frames/s and cut
to the cameras' view, y < 8 m).

    PEDVR_REAL_DATA=~/realdata python bench/entrance_observations.py --seeds 1 2 3 4

One JSON line per real file and per seed.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

LINE_Y = 7.5  # m: the crossing line, inside the corridor past the 0.7 m entrance (at y 8.0-8.2)
SMOOTH_S = 0.5  # s: window over a walking step's sway
VIEW_Y = 8.0  # m: the real cameras see the corridor up to here; pedvr's tracks are cut to it too
MOUTH = (0.9, 8.5, 0.8, 0.6)  # x, y centre and half extents of "just before the entrance" (pedvr)


def _tracks(path: Path) -> tuple[list[np.ndarray], float]:
    from pedvr.measure.trajectories import load_real

    run = load_real(path, unit="cm", fps=16.0)
    df = run.traj.data.sort_values(["id", "frame"])
    tracks = [np.column_stack([g["frame"].to_numpy() / run.traj.frame_rate, g["x"].to_numpy(),
                               g["y"].to_numpy()]) for _, g in df.groupby("id")]
    return tracks, float(run.traj.frame_rate)


def accelerations(tracks: list[np.ndarray], fps: float) -> dict[str, float]:
    w = max(1, round(SMOOTH_S * fps))
    acc = []
    for t in tracks:
        cut = 2 * w  # both smoothings' reach (w/2 each) and the gradients': the tracks' ends left out
        if len(t) <= 2 * cut + 2:
            continue
        xy = uniform_filter1d(t[:, 1:3], w, axis=0)
        v = np.gradient(xy, 1.0 / fps, axis=0)
        s = uniform_filter1d(np.hypot(v[:, 0], v[:, 1]), w)
        acc.append(np.gradient(s, 1.0 / fps)[cut:-cut])
    a = np.concatenate(acc)
    up, down = a[a > 0], -a[a < 0]

    def pct(x: np.ndarray, q: float) -> float:  # none speeding up (or slowing down): 0
        return round(float(np.percentile(x, q)), 2) if x.size else 0.0

    return {"accel_p95": pct(up, 95), "accel_p99": pct(up, 99), "decel_p99": pct(down, 99)}


def crossings(times: list[float], speeds: list[float]) -> dict[str, float]:
    g = np.diff(np.sort(np.asarray(times)))
    return {"crossed": len(times), "speed_median": round(float(np.median(speeds)), 2),
            "gap_median_s": round(float(np.median(g)), 3), "gap_mean_s": round(float(g.mean()), 3),
            "gap_p90_s": round(float(np.percentile(g, 90)), 3)}


def real_crossings(tracks: list[np.ndarray], fps: float) -> dict[str, float]:
    w = max(1, round(SMOOTH_S * fps))
    times, speeds = [], []
    for t in tracks:
        k = np.flatnonzero((t[:-1, 2] >= LINE_Y) & (t[1:, 2] < LINE_Y))
        if len(k) == 0:
            continue
        v = np.gradient(uniform_filter1d(t[:, 1:3], w, axis=0), 1.0 / fps, axis=0)
        times.append(float(t[k[0], 0]))
        speeds.append(float(np.hypot(*v[k[0]])))
    return crossings(times, speeds)


def pedvr_crossings(seed: int, until: float) -> dict[str, float]:
    from pedvr.crowd.orca import STATUS_DENSE
    from pedvr.scene.loader import load_any
    from pedvr.scenes import resolve_scene
    from pedvr.sim import Simulation

    sim = Simulation(load_any(resolve_scene("validation/uo_070"), seed=seed), seed=seed, condition="pedvr")
    times, speeds, near_speed = [], [], []
    near = dense = 0
    track: dict[int, list[tuple[float, float, float]]] = {}
    every = max(1, round(1.0 / (16.0 * sim.dt)))  # sampled at the real cameras' 16 frames/s
    while sim.t < until:
        before = dict(zip(sim.crowd.ids.tolist(), sim.crowd.pos[:, 1].tolist(), strict=True))
        sim.step()
        y = sim.crowd.pos[:, 1]
        for k, i in enumerate(sim.crowd.ids.tolist()):
            if before.get(i, -np.inf) >= LINE_Y > y[k]:
                times.append(sim.t)
                speeds.append(float(np.hypot(*sim.crowd.vel[k])))
        if sim.step_index % every == 0:
            for k, i in enumerate(sim.crowd.ids.tolist()):
                if not sim.crowd.is_user[k] and y[k] < VIEW_Y:
                    track.setdefault(i, []).append((sim.t, *sim.crowd.pos[k]))
        if len(sim.steering.last_status) != len(sim.crowd):
            continue  # a sink removed someone after steering
        m = (np.abs(sim.crowd.pos[:, 0] - MOUTH[0]) < MOUTH[2]) & (np.abs(y - MOUTH[1]) < MOUTH[3])
        near += int(m.sum())
        dense += int((m & ((sim.steering.last_status & STATUS_DENSE) > 0)).sum())
        near_speed.extend(np.hypot(sim.crowd.vel[m, 0], sim.crowd.vel[m, 1]).tolist())
    out = crossings(times, speeds)
    out.update(accelerations([np.asarray(t) for t in track.values()], 1.0 / (every * sim.dt)))
    out.update(before_mouth_speed=round(float(np.mean(near_speed)), 2),
               before_mouth_dense=round(dense / max(near, 1), 2))
    return out


def main(argv: list[str] | None = None) -> int:
    from pedvr.argtypes import count, positive

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=os.environ.get("PEDVR_REAL_DATA"),
                    help="real-data folder (PedPy's demo data)")
    ap.add_argument("--seeds", type=count, nargs="+", default=[1])
    ap.add_argument("--until", type=positive(float), default=60.0, help="simulated seconds of each pedvr run")
    a = ap.parse_args(argv)
    if a.data:
        folder = Path(a.data).expanduser() / "uni-directional"
        files = sorted(folder.glob("uo-*.txt"))
        if not files:
            ap.error(f"--data {a.data}: no {folder}/uo-*.txt (PedPy's notebooks/demo-data has them)")
        for f in files:
            tracks, fps = _tracks(f)
            row = {"real": f.name, **accelerations(tracks, fps)}
            if f.name.startswith("uo-070-"):
                row.update(real_crossings(tracks, fps))
            print(json.dumps(row), flush=True)
    else:
        print("no real data: set PEDVR_REAL_DATA or --data to PedPy's notebooks/demo-data", file=sys.stderr)
    for seed in a.seeds:
        print(json.dumps({"pedvr": "validation/uo_070", "seed": seed, "until_s": a.until,
                          **pedvr_crossings(seed, a.until)}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
