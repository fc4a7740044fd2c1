"""User pose sources for the interactive backends (PedVR §3.5: the user agent's input).

Pure logic, no glfw or OpenXR: the backends feed key states, mouse motion,
head poses and thumbstick values; the simulation reads poses through the
:class:`~pedvr.crowd.user.UserInput` protocol (``pose(t) -> (pos, heading)``).

* :class:`KeyboardMouseUser` (desktop): WASD / arrows walk at 1.3 m/s (a
  person's comfortable speed), Shift doubles it; the mouse turns (yaw) and
  looks up and down (pitch, the view only).
* :class:`HeadsetUser` (OpenXR): the tracked head pose, in the tracking
  space (LOCAL_FLOOR or STAGE), placed in the world by a :class:`PlaySpace`
  that thumbstick locomotion translates and snap turns rotate about the
  head; the user agent is the head projected to the floor, its heading the
  head's yaw.

Moves that would take the user's disc into an obstacle or out of the
bounds are refused along the blocked axis (sliding along walls); the user is
never steered by the crowd.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely

from pedvr.render.math3d import heading_of_direction, quat_to_matrix, rot_y
from pedvr.scene.config import WorldConfig

WALK_SPEED = 1.3  # m/s (issue 4; PedVR agents' preferred speed)
FAST_FACTOR = 2.0  # Shift
SNAP_TURN = math.radians(30.0)
SNAP_ARM = 0.3  # the stick must come back inside this before the next snap turn
SNAP_FIRE = 0.7
DEADZONE = 0.15
MAX_PITCH = math.radians(85.0)


class WalkableArea:
    """Membership test for the user's disc centre: inside the bounds minus obstacles, eroded by ``radius``."""

    def __init__(self, world: WorldConfig, *, radius: float) -> None:
        from pedvr.world import walkable_area

        area = walkable_area(world).buffer(-radius)
        self._area = area
        shapely.prepare(area)

    def contains(self, p: np.ndarray) -> bool:
        return bool(shapely.contains_xy(self._area, float(p[0]), float(p[1])))

    def slide(self, start: np.ndarray, end: np.ndarray) -> np.ndarray:
        """``end`` if reachable, else the move along x or y alone if that one is, else ``start``."""
        if self.contains(end):
            return end
        for cand in (np.array([end[0], start[1]]), np.array([start[0], end[1]])):
            if self.contains(cand):
                return cand
        return start


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class KeyboardMouseUser:
    """The desktop user: keys set a walking direction, the mouse the facing; :meth:`pose` integrates.

    ``forward`` and ``strafe`` are in [−1, 1] (W/S, D/A); the speed is
    :data:`WALK_SPEED` (× :data:`FAST_FACTOR` with ``fast``). :meth:`pose` is
    called by the simulation at its step times and integrates the current
    input from the previous call, so position follows simulation time, not
    the frame rate.
    """

    def __init__(
        self,
        *,
        start: tuple[float, float],
        heading: float,
        walkable: WalkableArea | None = None,
        speed: float = WALK_SPEED,
    ) -> None:
        self.pos = np.asarray(start, dtype=np.float64).copy()
        self.heading = float(heading)
        self.pitch = 0.0
        self.speed = speed
        self.walkable = walkable
        self._forward = 0.0
        self._strafe = 0.0
        self._fast = False
        self._t: float | None = None

    def set_keys(self, *, forward: float, strafe: float, fast: bool) -> None:
        """Current key state: ``forward`` +1 = W / Up, ``strafe`` +1 = D / Right; ``fast`` = Shift."""
        self._forward = float(np.clip(forward, -1, 1))
        self._strafe = float(np.clip(strafe, -1, 1))
        self._fast = bool(fast)

    def look(self, *, yaw: float, pitch: float) -> None:
        """Turn right by ``yaw`` rad (the 2D heading grows: math3d's chirality note); look up by ``pitch``."""
        self.heading = _wrap(self.heading + yaw)
        self.pitch = float(np.clip(self.pitch + pitch, -MAX_PITCH, MAX_PITCH))

    def velocity(self) -> np.ndarray:
        fwd = np.array([math.cos(self.heading), math.sin(self.heading)])
        right = np.array([-math.sin(self.heading), math.cos(self.heading)])  # heading + 90°: right in 3D
        d = self._forward * fwd + self._strafe * right
        n = float(np.linalg.norm(d))
        if n > 1.0:
            d /= n  # diagonal walking is not faster
        return d * self.speed * (FAST_FACTOR if self._fast else 1.0)

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        if self._t is not None and t > self._t:
            end = self.pos + self.velocity() * (t - self._t)
            self.pos = end if self.walkable is None else self.walkable.slide(self.pos, end)
        self._t = t if self._t is None else max(self._t, t)
        return self.pos.copy(), self.heading


# The 2D heading of tracking space's forward (−Z, where a head at rest looks) when tracking floor
# coordinates ``(x, z)`` are read as 2D ``(x, y)`` unrotated: atan2(−1, 0).
TRACKING_FORWARD = -math.pi / 2


@dataclass
class PlaySpace:
    """Where the tracking space lies in the world: 2D ``origin`` and ``yaw``, the world heading
    (rad, the 2D convention of :mod:`pedvr.render.math3d`) that tracking space's forward (−Z, where
    a head at rest looks) points to.

    A tracking-space point ``(x, y, z)`` (OpenXR, Y up) is at world
    ``origin + R(yaw − TRACKING_FORWARD)·(x, z)`` on the ground; in 3D the play
    space is ``T(origin) · R_y(−(yaw − TRACKING_FORWARD))`` (the 2D/3D handedness of
    :mod:`pedvr.render.math3d`), so a head at rest sees what
    :func:`~pedvr.render.math3d.first_person_rotation` ``(yaw)`` sees (issue 23 item 1: the
    play space's yaw was the rotation angle itself, and a participant started facing 90° left of
    the scene's heading).
    """

    origin: np.ndarray
    yaw: float = 0.0

    @property
    def _angle(self) -> float:
        return self.yaw - TRACKING_FORWARD

    def to_world_2d(self, p_tracking: np.ndarray) -> np.ndarray:
        c, s = math.cos(self._angle), math.sin(self._angle)
        x, z = float(p_tracking[0]), float(p_tracking[2])
        return self.origin + np.array([c * x - s * z, s * x + c * z])

    def heading_of(self, forward_tracking: np.ndarray) -> float:
        """World heading of a tracking-space direction (its floor projection)."""
        return _wrap(heading_of_direction(forward_tracking) + self._angle)

    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = rot_y(-self._angle)
        m[:3, 3] = (self.origin[0], 0.0, self.origin[1])
        return m


@dataclass(frozen=True)
class Controls:
    """One frame of controller input: ``move`` (left stick / trackpad: x right, y forward), ``turn``
    (right stick x), ``trigger`` and ``menu`` pressed this frame; ``trigger_hand`` the hand that
    pressed the trigger (0 left, 1 right, -1 not known)."""

    move: tuple[float, float] = (0.0, 0.0)
    turn: float = 0.0
    trigger: bool = False
    menu: bool = False
    trigger_hand: int = -1


class HeadsetUser:
    """The OpenXR user: head pose → user agent, thumbstick → locomotion, snap turn (issue 4).

    :meth:`track` takes each frame's head pose (tracking space, at the
    predicted display time ``t``) and controls; :meth:`pose` gives the user
    agent's floor position and heading at any simulation time, interpolated
    between the last two tracked samples (held, not extrapolated, beyond
    them). The play space starts with its forward (where a head at rest looks) on the scene's
    ``heading``, so the participant starts facing what the headless and desktop views face.
    Locomotion moves the play space in the direction the head faces;
    a snap turn rotates it by 30° about the head, so the user turns in place.
    """

    def __init__(
        self,
        *,
        start: tuple[float, float],
        heading: float,
        walkable: WalkableArea | None = None,
        speed: float = WALK_SPEED,
        snap: float = SNAP_TURN,
    ) -> None:
        self.space = PlaySpace(origin=np.asarray(start, dtype=np.float64).copy(), yaw=float(heading))
        self.walkable = walkable
        self.speed = speed
        self.snap = snap
        self._armed = True
        self._samples: list[tuple[float, np.ndarray, float]] = []
        self._head_tracking: np.ndarray | None = None
        self._head_forward: np.ndarray = np.array([0.0, 0.0, -1.0])
        self.moving_speed = 0.0
        self.snap_turns = 0

    # -- head ------------------------------------------------------------------------------

    def head_world(self) -> tuple[np.ndarray, float]:
        """Floor position and heading of the head in the world now."""
        if self._head_tracking is None:
            return self.space.origin.copy(), self.space.yaw
        return self.space.to_world_2d(self._head_tracking), self.space.heading_of(self._head_forward)

    def track(
        self,
        *,
        t: float,
        position: np.ndarray,
        orientation: tuple[float, float, float, float] | None,
        controls: Controls,
        dt: float,
    ) -> None:
        """One frame: head pose in tracking space (None orientation = not tracked), controls, frame ``dt``."""
        if orientation is not None:
            self._head_tracking = np.asarray(position, dtype=np.float64).copy()
            self._head_forward = quat_to_matrix(*orientation) @ np.array([0.0, 0.0, -1.0])
        self._locomote(controls, dt)
        self._snap_turn(controls.turn)
        p, h = self.head_world()
        self._samples.append((t, p, h))
        del self._samples[:-2]

    def _locomote(self, c: Controls, dt: float) -> None:
        x, y = c.move
        mag = math.hypot(x, y)
        if mag < DEADZONE or dt <= 0:
            self.moving_speed = 0.0
            return
        scale = min(1.0, (mag - DEADZONE) / (1.0 - DEADZONE)) / mag
        _, h = self.head_world()
        fwd = np.array([math.cos(h), math.sin(h)])
        right = np.array([-math.sin(h), math.cos(h)])  # heading + 90°: the user's right in 3D
        v = (y * fwd + x * right) * scale * self.speed
        self.moving_speed = float(np.linalg.norm(v))
        head, _ = self.head_world()
        target = head + v * dt
        reached = target if self.walkable is None else self.walkable.slide(head, target)
        self.space.origin = self.space.origin + (reached - head)

    def _snap_turn(self, x: float) -> None:
        if abs(x) < SNAP_ARM:
            self._armed = True
            return
        if not self._armed or abs(x) < SNAP_FIRE:
            return
        self._armed = False
        head, _ = self.head_world()
        # Stick right = turn right = clockwise seen from above = the 2D yaw grows (chirality note, math3d).
        self.space.yaw = _wrap(self.space.yaw + math.copysign(self.snap, x))
        # Keep the head where it is in the world: rotate the play space about it.
        moved, _ = self.head_world()
        self.space.origin = self.space.origin + (head - moved)
        self.snap_turns += 1

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        if not self._samples:
            return self.head_world()
        if len(self._samples) == 1 or t >= self._samples[-1][0]:
            return self._samples[-1][1].copy(), self._samples[-1][2]
        (t0, p0, h0), (t1, p1, h1) = self._samples
        if t <= t0 or t1 <= t0:
            return p0.copy(), h0
        a = (t - t0) / (t1 - t0)
        return p0 + a * (p1 - p0), _wrap(h0 + a * _wrap(h1 - h0))

    def floor_point(self, position: np.ndarray) -> tuple[float, float]:
        """The world floor point under a tracking-space position (a controller's grip)."""
        p = self.space.to_world_2d(np.asarray(position, dtype=np.float64))
        return float(p[0]), float(p[1])

    def eye_world_pose(self, *, rotation: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World rotation and position of an eye given in tracking space (for the per-eye views)."""
        m = self.space.matrix()
        return m[:3, :3] @ rotation, m[:3, :3] @ np.asarray(position, dtype=np.float64) + m[:3, 3]
