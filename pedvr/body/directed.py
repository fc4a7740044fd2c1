"""Body capabilities driven by plans made elsewhere (the demonstrator, PLACE §6–8).

:class:`HandPaths` moves a reaching hand along a timed path: the reach
choreographer's target (``BodyState.reach_pt``) is set from the path at every
step, interpolated in time, so the arm IK follows a trajectory planned at the
decision rate without 30 Hz jumps. :class:`HeadCaps` caps, per agent, how far
the gaze chain (lumbar, thorax, neck and head) may turn in yaw, the eyes doing
the rest within their own limit: Appendix A's maximum head rotation φ.
:class:`HeldFacings` keeps an agent facing a given way while it moves (a
short side step or back step to a new placement, §5) instead of turning to
face its motion: the facing turns toward the held heading at the standing
turn rate.

Both are per-agent entries keyed by the agent's id (stable across row
changes), so they survive agents being added and removed; an entry whose
agent is gone is dropped at the next use.
"""

from __future__ import annotations

import numpy as np


class HandPaths:
    """Timed hand paths per (agent id, arm): ``times (M,)`` increasing, ``points (M, 3)`` world."""

    def __init__(self) -> None:
        self.paths: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}

    def set(self, agent: int, side: int, times: np.ndarray, points: np.ndarray) -> None:
        t = np.asarray(times, np.float64).reshape(-1)
        p = np.asarray(points, np.float64).reshape(-1, 3)
        if t.shape[0] != p.shape[0] or t.shape[0] == 0:
            raise ValueError(f"hand path: {t.shape[0]} times for {p.shape[0]} points; need one per point")
        if np.any(np.diff(t) < 0.0):
            raise ValueError("hand path: times must not decrease")
        self.paths[(int(agent), int(side))] = (t, p)

    def clear(self, agent: int, side: int) -> None:
        self.paths.pop((int(agent), int(side)), None)

    def apply(self, ids: np.ndarray, reach_on: np.ndarray, reach_pt: np.ndarray, t: float) -> None:
        """Set ``reach_pt`` of every row with a path (its arm reaching) to the path's point at ``t``.

        Before the first time the first point holds, after the last the last.
        A path whose arm was released, or whose agent is gone, is dropped.
        """
        if not self.paths:
            return
        rows = {int(a): r for r, a in enumerate(ids.tolist())}
        for key in list(self.paths):
            agent, side = key
            r = rows.get(agent)
            if r is None or not reach_on[r, side]:
                del self.paths[key]
                continue
            times, pts = self.paths[key]
            for k in range(3):
                reach_pt[r, side, k] = np.interp(t, times, pts[:, k])


class HeadCaps:
    """Per-agent caps (rad) on the total yaw of the gaze chain's body joints."""

    def __init__(self) -> None:
        self.caps: dict[int, float] = {}
        self._uncapped: tuple[np.ndarray, np.ndarray] | None = None  # (base, table) without caps

    def set(self, agent: int, yaw: float | None) -> None:
        if yaw is None:
            self.caps.pop(int(agent), None)
        else:
            self.caps[int(agent)] = max(float(yaw), 0.0)

    def rows(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, caps)`` of the capped agents present in ``ids``; gone agents are dropped."""
        if not self.caps:
            return np.zeros(0, np.int64), np.zeros(0)
        rows = {int(a): r for r, a in enumerate(ids.tolist())}
        for gone in [a for a in self.caps if a not in rows]:
            del self.caps[gone]
        keys = sorted(self.caps)
        return (np.asarray([rows[a] for a in keys], np.int64), np.asarray([self.caps[a] for a in keys]))

    def table(self, ids: np.ndarray, base: np.ndarray) -> np.ndarray:
        """``(N, 5)`` yaw limits per row for the pose graph: ``base`` everywhere, :meth:`limits` where
        an agent's gaze is capped. Without caps the same table serves every step while the crowd's
        size and ``base`` (the same array) stay the same: callers only read it."""
        if not self.caps:
            last = self._uncapped
            if last is not None and last[0] is base and last[1].shape[0] == len(ids):
                return last[1]
        out = np.tile(np.asarray(base, np.float64), (len(ids), 1))
        if not self.caps:
            self._uncapped = (base, out)
        if self.caps:
            rows, caps = self.rows(ids)
            for r, cap in zip(rows.tolist(), caps.tolist(), strict=True):
                out[r] = self.limits(base, cap)
        return out

    @staticmethod
    def limits(base: np.ndarray, cap: float) -> np.ndarray:
        """Yaw limits ``(5,)`` (lumbar, thorax, neck, head, eyes) whose body joints sum to at most ``cap``:
        each body joint's limit scaled by the same factor; the eyes keep theirs."""
        out = np.array(base, np.float64)
        total = float(out[:4].sum())
        if cap < total:
            out[:4] *= cap / max(total, 1e-9)
        return out


class HeldFacings:
    """Per-agent headings (rad) held while moving; applied after the root motion (coupled only)."""

    def __init__(self) -> None:
        self.held: dict[int, float] = {}

    def set(self, agent: int, heading: float | None) -> None:
        if heading is None:
            self.held.pop(int(agent), None)
        else:
            self.held[int(agent)] = float(heading)

    def apply(self, ids: np.ndarray, current: np.ndarray, heading: np.ndarray, rate: np.ndarray,
              dt: float) -> None:
        """``heading (N,)`` (the root motion's proposal) of every held row replaced by ``current``
        turned toward the held heading, at most ``rate[row]`` rad/s; gone agents are dropped."""
        if not self.held:
            return
        rows = {int(a): r for r, a in enumerate(ids.tolist())}
        for agent in list(self.held):
            r = rows.get(agent)
            if r is None:
                del self.held[agent]
                continue
            delta = (self.held[agent] - float(current[r]) + np.pi) % (2.0 * np.pi) - np.pi
            lim = float(rate[r]) * dt
            h = float(current[r]) + min(max(delta, -lim), lim)
            heading[r] = (h + np.pi) % (2.0 * np.pi) - np.pi
