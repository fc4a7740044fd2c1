"""numba kernels that run in parallel only when the work is worth it.

A ``prange`` loop is a fork–join: every launch waits for every worker
thread. For the tens of agents of a VR scene that wait costs more than the
work, and on a busy machine (a renderer thread, a compositor) a worker that
is descheduled stalls the whole step for milliseconds. So each parallel
kernel gets a serial twin compiled from the same source, and a call picks
the parallel one only when its first argument has at least ``min_rows``
rows. Results do not depend on the choice: the kernels' outputs are written
per row, with no reductions across threads.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any

from numba import njit

PARALLEL_MIN_ROWS = 512


class SizeDispatch:
    """Call ``parallel`` when ``args[0].shape[0] >= min_rows``, else ``serial``."""

    def __init__(self, parallel: Any, serial: Any, min_rows: int) -> None:
        self.parallel = parallel
        self.serial = serial
        self.min_rows = min_rows
        self.__doc__ = parallel.py_func.__doc__
        self.__wrapped__ = parallel.py_func

    def __call__(self, *args: Any) -> Any:
        n = args[0].shape[0]
        return (self.parallel if n >= self.min_rows else self.serial)(*args)


def parallel_kernel(*, fastmath: Any = False,
                    min_rows: int = PARALLEL_MIN_ROWS) -> Callable[[Any], SizeDispatch]:
    """Decorator: ``njit(cache=True, parallel=True)`` plus a serial twin.

    The twin gets its own qualified name so numba's on-disk cache keeps the
    two compilations apart.
    """

    def wrap(f: Callable[..., Any]) -> SizeDispatch:
        par = njit(cache=True, parallel=True, fastmath=fastmath)(f)
        twin = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "_serial", f.__defaults__,
                                  f.__closure__)
        twin.__qualname__ = f.__qualname__ + "_serial"
        twin.__module__ = f.__module__
        ser = njit(cache=True, fastmath=fastmath)(twin)
        return SizeDispatch(par, ser, min_rows)

    return wrap
