"""The error the measure layer raises at its boundary (bad files, flags, geometry)."""

from __future__ import annotations

from pedvr.errors import PedvrError


class MeasureError(PedvrError):
    """A recording, trajectory file, measurement area or line cannot be measured; one line that
    names what and why (the CLI prints it and exits 2)."""

    exit_code = 2
