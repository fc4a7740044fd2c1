"""A problem collector for TOML files: scenes, protocols, questionnaires.

Every accessor records a problem line ``file: dotted.key = value: expectation``
and returns ``None`` instead of raising, so a file's problems are reported all
at once (STYLE.md habit 10). Required keys never default silently.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

MISSING: Any = object()


def fmt(v: object) -> str:
    if v is MISSING:
        return "<missing>"
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, dict):
        return "{...}"
    return str(v).replace("'", '"')


def is_num(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(float(v))


class Checker:
    """Collects problems for one file; ``problems`` lists them in file order."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.problems: list[str] = []

    def bad(self, key: str, value: object, why: str) -> None:
        self.problems.append(f"{self.source}: {key} = {fmt(value)}: {why}")

    def known(self, d: dict[str, Any], path: str, allowed: tuple[str, ...]) -> None:
        for k in d:
            if k not in allowed:
                self.bad(
                    f"{path}.{k}" if path else k, d[k], f"unknown key; expected one of {', '.join(allowed)}"
                )

    def table(self, d: dict[str, Any], key: str, path: str, *, required: bool) -> dict[str, Any] | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, "required table")
            return None
        if not isinstance(v, dict):
            self.bad(path, v, "expected a table")
            return None
        return v

    def tables(self, d: dict[str, Any], key: str, path: str, *, required: bool) -> list[dict[str, Any]]:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, f"required array of tables [[{path}]]")
            return []
        if not isinstance(v, list) or not all(isinstance(x, dict) for x in v) or (required and not v):
            self.bad(path, v, f"expected a non-empty array of tables [[{path}]]")
            return []
        return v

    def string(
        self,
        d: dict[str, Any],
        key: str,
        path: str,
        *,
        required: bool = True,
        default: str | None = None,
        choices: tuple[str, ...] | None = None,
    ) -> str | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, "required string" + (f" (one of {', '.join(choices)})" if choices else ""))
            return default
        if not isinstance(v, str) or (required and not v.strip()):
            self.bad(path, v, "expected a non-empty string")
            return None
        if choices is not None and v not in choices:
            self.bad(path, v, f"expected one of {', '.join(repr(c) for c in choices)}")
            return None
        return v

    def number(
        self,
        d: dict[str, Any],
        key: str,
        path: str,
        *,
        required: bool = True,
        default: float | None = None,
        check: Callable[[float], bool] | None = None,
        expect: str = "",
    ) -> float | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, f"required number{' ' + expect if expect else ''}")
            return default
        if not is_num(v):
            self.bad(path, v, f"expected a number{' ' + expect if expect else ''}")
            return None
        if check is not None and not check(float(v)):
            self.bad(path, v, f"must be {expect}")
            return None
        return float(v)

    def integer(
        self,
        d: dict[str, Any],
        key: str,
        path: str,
        *,
        required: bool = True,
        default: int | None = None,
        check: Callable[[int], bool] | None = None,
        expect: str = "",
    ) -> int | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, f"required integer{' ' + expect if expect else ''}")
            return default
        if not isinstance(v, int) or isinstance(v, bool):
            self.bad(path, v, f"expected an integer{' ' + expect if expect else ''}")
            return None
        if check is not None and not check(v):
            self.bad(path, v, f"must be {expect}")
            return None
        return v

    def boolean(self, d: dict[str, Any], key: str, path: str, *, default: bool) -> bool:
        v = d.get(key, MISSING)
        if v is MISSING:
            return default
        if not isinstance(v, bool):
            self.bad(path, v, "expected true or false")
            return default
        return v

    def strings(
        self,
        d: dict[str, Any],
        key: str,
        path: str,
        *,
        required: bool = True,
        default: tuple[str, ...] = (),
        minimum: int = 1,
    ) -> tuple[str, ...] | None:
        v = d.get(key, MISSING)
        if v is MISSING:
            if required:
                self.bad(path, v, "required array of strings")
            return default
        if not isinstance(v, list) or len(v) < minimum or not all(isinstance(x, str) and x for x in v):
            self.bad(path, v, f"expected an array of at least {minimum} non-empty strings")
            return None
        return tuple(v)
