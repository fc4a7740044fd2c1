"""The exceptions pedvr raises at its public boundaries.

Every error a user can cause (a bad scene file, a bad CLI flag, a backend that
cannot start) is a subclass of :class:`PedvrError`; the CLI prints its message
as one line (or one line per problem) and exits non-zero, never a traceback.
"""

from __future__ import annotations


class PedvrError(Exception):
    """Base class of every error pedvr raises on purpose."""

    exit_code = 1


class SceneError(PedvrError):
    """A scene file (TOML or SteerSuite XML) is invalid.

    ``problems`` holds one line per problem, each of the form
    ``scenes/x.toml: agents.profiles.child.radius = -0.2: must be > 0``; the
    message is those lines joined, so every problem is reported at once.
    """

    exit_code = 2

    def __init__(self, problems: list[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class NavigationError(PedvrError):
    """The navigation mesh cannot be built or a query is outside it."""


class BackendUnavailableError(PedvrError):
    """A presentation backend (openxr, desktop) cannot start on this machine."""

    exit_code = 3


class UsageError(PedvrError):
    """A command-line flag or argument is invalid."""

    exit_code = 2
