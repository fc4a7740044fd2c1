"""Published relations of pedestrian dynamics, as formulas (see shared/references/crowd-data.md).

These are the references every run is compared with when no real trajectories
are at hand; they need no data and are always available.
"""

from __future__ import annotations

import numpy as np

FREE_SPEED = 1.34  # m/s: Weidmann's mean free walking speed
JAM_DENSITY = 5.4  # persons/m²: Weidmann's density at which v = 0
GAMMA = 1.913  # persons/m²: Weidmann's shape constant
BOTTLENECK_SPECIFIC_FLOW = 1.9  # persons/(m s): Seyfried et al. 2009's J/b, middle of the 1.6-2.0 band
BOTTLENECK_SPECIFIC_FLOW_BAND = (1.6, 2.0)
NARROW_BOTTLENECK_FLOW = 1.15  # persons/s through a 0.5 m bottleneck in dense experiments (1.1-1.2)


def weidmann_speed(density: float | np.ndarray) -> float | np.ndarray:
    """Weidmann's (1993) fundamental diagram, planar and uni-directional:
    ``v(ρ) = 1.34 (1 - exp(-1.913 (1/ρ - 1/5.4)))`` m/s for ρ in persons/m², 0 at and above 5.4,
    1.34 at ρ → 0."""
    rho = np.asarray(density, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = FREE_SPEED * (1.0 - np.exp(-GAMMA * (1.0 / rho - 1.0 / JAM_DENSITY)))
    v = np.where(rho <= 0.0, FREE_SPEED, np.where(rho >= JAM_DENSITY, 0.0, v))
    return float(v) if np.ndim(v) == 0 else v


def weidmann_specific_flow(density: float | np.ndarray) -> float | np.ndarray:
    """``J_s = ρ v(ρ)`` persons/(m s): Weidmann's flow per metre of width."""
    return np.asarray(density, np.float64) * weidmann_speed(density)


def bottleneck_flow(width: float) -> float:
    """Flow (persons/s) through a bottleneck ``width`` m wide: Seyfried et al. 2009's linear growth
    with width, ``J = J_s b`` with ``J_s = 1.9`` persons/(m s) (the middle of the 1.6-2.0 band of
    crowd-data.md). Below 0.8 m, where the line was not measured, the dense experiments' 1.15 /s at
    0.5 m is used, linearly joined to the line at 0.8 m (pedvr's choice: no published formula covers
    the narrowest openings, where people pass by turning their shoulders)."""
    if width >= 0.8:
        return BOTTLENECK_SPECIFIC_FLOW * width
    w0, j0 = 0.5, NARROW_BOTTLENECK_FLOW
    j1 = BOTTLENECK_SPECIFIC_FLOW * 0.8
    return j0 + (j1 - j0) * (width - w0) / (0.8 - w0)
