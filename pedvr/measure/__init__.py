"""The field's measures through PedPy, on pedvr runs and real trajectories alike (DESIGN.md, measure).

* :mod:`pedvr.measure.trajectories`: recordings, live simulations and real files as PedPy data;
* :mod:`pedvr.measure.measures`: Voronoi density and speed, flow, time gaps, N(t), steady state,
  the fundamental diagram;
* :mod:`pedvr.measure.references`: Weidmann's diagram and the bottleneck flow-width relation;
* :mod:`pedvr.measure.cases`: the validation scenes, their measurement set-ups and real data;
* :mod:`pedvr.measure.realism`: ``pedvr bench realism``; :mod:`pedvr.measure.plots`: figures.
"""

from pedvr.measure.errors import MeasureError
from pedvr.measure.measures import Measures, Setup, measure, steady_window, walkable_polygon
from pedvr.measure.trajectories import Run, from_arrays, from_recording, from_simulation, load_real

__all__ = [
    "MeasureError",
    "Measures",
    "Run",
    "Setup",
    "from_arrays",
    "from_recording",
    "from_simulation",
    "load_real",
    "measure",
    "steady_window",
    "walkable_polygon",
]
