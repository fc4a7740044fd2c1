"""Typed registries: the extension points scenes can name.

A scene may only name registered things; an unknown name gets an error that
lists the known ones (STYLE.md, habit 6).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Generic, TypeVar

T = TypeVar("T")


class Registry(Generic[T]):
    """Name → entry. ``@reg.register("name")`` adds a class or function."""

    def __init__(self, what: str) -> None:
        self.what = what
        self._entries: dict[str, T] = {}

    def register(self, name: str) -> Callable[[T], T]:
        def add(entry: T) -> T:
            if name in self._entries:
                raise ValueError(f"{self.what} {name!r} is already registered")
            self._entries[name] = entry
            return entry

        return add

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __getitem__(self, name: str) -> T:
        try:
            return self._entries[name]
        except KeyError:
            raise KeyError(self.unknown(name)) from None

    def __iter__(self) -> Iterator[str]:
        return iter(sorted(self._entries))

    def unknown(self, name: object) -> str:
        return f"unknown {self.what} {name!r}; known: {', '.join(sorted(self._entries))}"
