"""Which way two bodies at the same point separate (issue 24, item 1).

Two centres can coincide: spawns at one position, a teleport, an agent source,
the user's head moving onto an agent. Every pair rule of the step (ORCA's
collision line, the contact pass, the push out of the user) moves a body along
the line of centres, which then has no direction. Those rules take it from
:func:`apart` instead, so that no input crashes a step or leaves a NaN.

The rule (pedvr's choice; RVO2 divides by zero here): give row ``k`` a
*virtual offset* ``o_k = sqrt(k + 1/2) (cos kφ, sin kφ)`` with ``φ`` the
golden angle (Vogel's sunflower spiral, whose points are all distinct and
spread evenly round the origin), and let row ``i`` leave row ``j`` along
``(o_i - o_j) / |o_i - o_j|``:

* it is antisymmetric, ``apart(j, i) = -apart(i, j)``: both rows of a pair are
  computed from the same snapshot and move opposite ways, so "compute, then
  apply" holds and a pair's pushes cancel (its centroid stays put);
* many rows at one point spread in two dimensions, as if each had been
  displaced a little toward its virtual offset, not along one line (a fixed axis
  would line five bodies up across a narrow corridor, where walls push them back
  for ever);
* it depends only on the two rows, so the same state gives the same bytes, with
  any thread count. Rows are in id order in a :class:`pedvr.sim.Simulation`
  (agents are appended with new ids, removals keep the order), so the direction
  is the same for the same two agents whatever else came or went.

Centres closer than :data:`COINCIDENT` (m) count as coincident: below that the
difference of two positions says nothing about a direction worth following.
"""

from __future__ import annotations

import math

from pedvr.kernels import row_njit

COINCIDENT = 1e-12  # m: centres closer than this have no line of centres
GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


@row_njit()  # not inlined: it runs only where centres coincide, and stays out of the hot loops
def apart(i, j):  # type: ignore[no-untyped-def]
    """Unit direction ``(x, y)`` in which row ``i`` leaves row ``j`` when their centres
    coincide (see the module docstring); ``apart(j, i)`` is its opposite. ``i != j``."""
    ri = math.sqrt(i + 0.5)
    rj = math.sqrt(j + 0.5)
    dx = ri * math.cos(i * GOLDEN_ANGLE) - rj * math.cos(j * GOLDEN_ANGLE)
    dy = ri * math.sin(i * GOLDEN_ANGLE) - rj * math.sin(j * GOLDEN_ANGLE)
    d = math.sqrt(dx * dx + dy * dy)
    return dx / d, dy / d
