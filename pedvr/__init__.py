"""pedvr: virtual pedestrians around a real person (see README.md and DESIGN.md)."""

import os as _os

__version__ = "0.2.0"

# numba's parallel kernels run on GNU OpenMP here. By default its idle worker
# threads spin before they sleep; when the cores are shared (a renderer, a
# compositor, the OpenXR runtime, another process) the spinning threads and
# the fork-joins fight over them and a parallel region of the ORCA step took
# 16 ms instead of 0.7 ms (issue 12; /tmp measurement in the commit that set
# this). Passive waiting: idle workers sleep at once. Set before numba loads
# OpenMP; a value the user exported wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
