"""The errors ``pedvr sweep`` raises at its boundaries (subclasses of :class:`PedvrError`)."""

from __future__ import annotations

from pedvr.errors import PedvrError


class SweepSpecError(PedvrError):
    """A sweep spec is invalid: ``problems`` holds one line per problem, all of them at once,
    each ``spec.toml: dotted.key = value: expectation`` (as scene files report theirs)."""

    exit_code = 2

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class SweepError(PedvrError):
    """A sweep cannot start or go on: the output folder, the scheduler, the workers, the extra."""

    exit_code = 2
