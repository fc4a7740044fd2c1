"""Argument types shared by the command lines (``pedvr``, ``pedvr sweep``, ``pedvr study``,
``pedvr measure``): each turns a bad value into argparse's one-line error naming it."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def positive(kind: Callable[[str], float]) -> Callable[[str], float]:
    """A finite number > 0 of type ``kind`` (``float`` or ``int``)."""

    def parse(text: str) -> float:
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{text!r} must be a finite number > 0")
        if v <= 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
        return v

    return parse


def count(text: str) -> int:
    """An integer >= 0."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be an integer >= 0")
    return v


def field_of_view(text: str) -> float:
    """A field of view in degrees, strictly between 0 and 180."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 < v < 180.0:
        raise argparse.ArgumentTypeError(f"{text!r} must be between 0 and 180 degrees")
    return v
