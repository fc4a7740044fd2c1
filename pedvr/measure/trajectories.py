"""Trajectories as PedPy sees them: pedvr recordings, live runs and real experiment files.

A pedvr recording (``.npz``, README "Outputs") holds every step at the
simulation's rate (90 Hz by default) with NaN where an agent is absent. PedPy
wants a table of ``id, frame, x, y`` at a frame rate; :func:`from_arrays`
keeps every ``k``-th step so that the frame rate is close to the one asked
for (16 frames/s by default, the rate of the Jülich corridor recordings), drops
absent rows and the user (the person is not one of the crowd whose flow is
measured), and keeps the stable ids. Real files go through PedPy's own loaders
(:func:`load_real`), so a real experiment and a pedvr run are measured by the
same code.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pedvr.measure.errors import MeasureError

if TYPE_CHECKING:
    import pedpy

    from pedvr.sim import Simulation

DEFAULT_FPS = 16.0  # frames/s kept from a recording (the Jülich corridor recordings' rate)


@dataclass(frozen=True)
class Run:
    """Trajectories ready for PedPy and what they came from.

    ``traj`` is PedPy's TrajectoryData (metres, frames at ``traj.frame_rate``);
    ``agents`` how many distinct people it holds; ``label`` names the run in
    tables and plots; ``meta`` is the recording's meta (scene, seed, condition)
    or the real file's name; ``source`` the scene file of a pedvr run (None
    for real data).
    """

    traj: pedpy.TrajectoryData
    agents: int
    label: str
    meta: dict[str, Any]
    source: str | None = None


def from_arrays(
    t: np.ndarray,
    pos: np.ndarray,
    *,
    ids: np.ndarray,
    is_user: np.ndarray | None = None,
    fps: float = DEFAULT_FPS,
    label: str = "run",
    meta: dict[str, Any] | None = None,
    source: str | None = None,
) -> Run:
    """A recording's arrays (``t (S,)`` s, ``pos (S, A, 2)`` m, NaN where absent, ``ids (A,)``,
    ``is_user (A,)``) as PedPy trajectories at about ``fps`` frames/s (every
    ``round((1/dt) / fps)``-th step; the frame rate given to PedPy is the exact one kept)."""
    import pandas as pd
    import pedpy

    t = np.asarray(t, np.float64)
    pos = np.asarray(pos, np.float64)
    if t.ndim != 1 or pos.ndim != 3 or pos.shape[0] != t.shape[0] or pos.shape[2] != 2:
        raise MeasureError(f"{label}: expected t (S,) and pos (S, A, 2); got {t.shape} and {pos.shape}")
    if t.shape[0] < 2:
        raise MeasureError(f"{label}: a recording of {t.shape[0]} step(s) has no motion to measure")
    if not fps > 0:
        raise MeasureError(f"--fps {fps}: expected a frame rate > 0")
    dt = float(np.median(np.diff(t)))
    every = max(1, round((1.0 / dt) / fps))
    keep_cols = np.ones(pos.shape[1], np.bool_) if is_user is None else ~np.asarray(is_user, np.bool_)
    p = pos[::every][:, keep_cols]
    agent_ids = np.asarray(ids)[keep_cols]
    frames = np.arange(p.shape[0])
    # the frame numbers of the kept steps, counted from the recording's t = 0
    first = round(float(t[0]) / (dt * every))
    f_idx, a_idx = np.nonzero(~np.isnan(p[..., 0]))
    data = (
        pd.DataFrame(
            {
                "id": agent_ids[a_idx].astype(np.int64),
                "frame": (frames[f_idx] + first).astype(np.int64),
                "x": p[f_idx, a_idx, 0],
                "y": p[f_idx, a_idx, 1],
            }
        )
        .sort_values(["id", "frame"], kind="stable")
        .reset_index(drop=True)
    )
    if data.empty:
        raise MeasureError(f"{label}: no agent in the recording (the user is not measured)")
    traj = pedpy.TrajectoryData(data=data, frame_rate=1.0 / (dt * every))
    return Run(
        traj=traj, agents=int(np.unique(data["id"]).size), label=label, meta=dict(meta or {}), source=source
    )


def from_recording(path: str | Path, *, fps: float = DEFAULT_FPS, label: str | None = None) -> Run:
    """A pedvr recording (``pedvr run --record FILE.npz``) as PedPy trajectories."""
    p = Path(path)
    if not p.is_file():
        raise MeasureError(f"{p}: no such recording")
    try:
        with np.load(p, allow_pickle=False) as z:
            missing = [k for k in ("t", "ids", "pos", "is_user", "meta") if k not in z]
            if missing:
                raise MeasureError(f"{p}: not a pedvr recording (no {', '.join(missing)})")
            t, ids, pos, is_user = z["t"], z["ids"], z["pos"], z["is_user"]
            meta = json.loads(str(z["meta"]))
    except (OSError, ValueError, zipfile.BadZipFile, json.JSONDecodeError) as exc:
        raise MeasureError(f"{p}: not a readable .npz recording ({exc})") from None
    name = label or (
        f"{meta.get('scene', p.stem)} ({meta.get('condition', '?')}, seed {meta.get('seed', '?')})"
    )
    return from_arrays(
        t, pos, ids=ids, is_user=is_user, fps=fps, label=name, meta=meta, source=meta.get("source")
    )


def from_simulation(sim: Simulation, *, fps: float = DEFAULT_FPS, label: str | None = None) -> Run:
    """A live :class:`pedvr.sim.Simulation` made with ``record=True``, measured as it stands."""
    if sim.recording is None:
        raise MeasureError("the simulation keeps no trajectory: create it with record=True")
    a = sim.recording.arrays()
    meta = {
        "scene": sim.scene.name,
        "seed": sim.seed,
        "condition": sim.condition,
        "scene_hash": sim.scene.content_hash,
    }
    return from_arrays(
        a["t"],
        a["pos"],
        ids=a["ids"],
        is_user=a["is_user"],
        fps=fps,
        label=label or f"{sim.scene.name} ({sim.condition}, seed {sim.seed})",
        meta=meta,
        source=sim.scene.source,
    )


UNITS = {"m": "METER", "cm": "CENTIMETER"}


def load_real(
    path: str | Path, *, unit: str | None = None, fps: float | None = None, label: str | None = None
) -> Run:
    """A real experiment's trajectory file through PedPy's loaders.

    Text files (PeTrack's ``id frame x y [z]``) use :func:`pedpy.load_trajectory`; the
    unit and frame rate come from the file's header where it has them (the Wuppertal
    bottleneck's), else from ``unit`` (``m`` or ``cm``) and ``fps`` (the Jülich
    corridor files: cm, 16 frames/s). ``.h5`` files from the Jülich data archive use
    :func:`pedpy.load_trajectory_from_ped_data_archive_hdf5`."""
    import pedpy

    p = Path(path)
    if not p.is_file():
        raise MeasureError(f"{p}: no such trajectory file")
    try:
        if p.suffix == ".h5":
            traj = pedpy.load_trajectory_from_ped_data_archive_hdf5(trajectory_file=p)
        else:
            if unit is not None and unit not in UNITS:
                raise MeasureError(f"--unit {unit!r}: expected one of {', '.join(UNITS)}")
            kw: dict[str, Any] = {}
            if unit is not None:
                kw["default_unit"] = getattr(pedpy.TrajectoryUnit, UNITS[unit])
            if fps is not None:
                kw["default_frame_rate"] = float(fps)
            traj = pedpy.load_trajectory(trajectory_file=p, **kw)
    except pedpy.PedPyError as exc:
        raise MeasureError(
            f"{p}: PedPy could not load it ({exc}); give --unit m|cm and --fps N "
            "where the file's header does not say"
        ) from None
    n = int(traj.data["id"].nunique())
    return Run(traj=traj, agents=n, label=label or p.stem, meta={"file": p.name})
