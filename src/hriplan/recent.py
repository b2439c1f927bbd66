"""The last few things made, kept by key, the most recent last.

Planning makes the same things again and again (a scene's collision build, a person's arm IK, a
derivation, a monitor's pair geometry); each home keeps the last few it made here and finds one
again while it is among them.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

K = TypeVar("K")
V = TypeVar("V")


class Recent(Generic[K, V]):
    """At most `size` values by key; a use or a put makes a value the most recent, and a put
    beyond `size` forgets the least recent."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._items: dict[K, V] = {}

    def get(self, key: K) -> V | None:
        value = self._items.pop(key, None)
        if value is not None:
            self._items[key] = value
        return value

    def put(self, key: K, value: V) -> None:
        self._items.pop(key, None)
        self._items[key] = value
        while len(self._items) > self.size:
            self._items.pop(next(iter(self._items)))

    def __len__(self) -> int:
        return len(self._items)

    def clear(self) -> None:
        self._items.clear()


class MadeFor(Generic[V]):
    """The last few values made for some objects, found again by those very objects (identity, not
    equality: pinocchio models, robots) and an extra key. Keyed by the objects' ids, each entry
    holding the objects, so that no other object takes one of their ids while it is kept."""

    def __init__(self, size: int) -> None:
        self._recent: Recent[tuple, tuple[tuple, V]] = Recent(size)

    def get(self, objects: tuple, extra: Hashable = None) -> V | None:
        kept = self._recent.get((*map(id, objects), extra))
        return None if kept is None or any(a is not b for a, b in zip(kept[0], objects)) else kept[1]

    def put(self, objects: tuple, value: V, extra: Hashable = None) -> None:
        self._recent.put((*map(id, objects), extra), (objects, value))

    def made(self, objects: tuple, make: Callable[[], V], extra: Hashable = None) -> V:
        """The value kept for `objects` and `extra`, else `make()`'s, kept."""
        value = self.get(objects, extra)
        if value is None:
            value = make()
            self.put(objects, value, extra)
        return value
