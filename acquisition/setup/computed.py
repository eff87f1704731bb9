"""Sequences whose items are computed from their index: the steps of a straightness run and the
stops of a positioning cycle hold a few numbers whatever their length (sizes are checked against
acquisition/setup/maxima.py, and a plan reads one item at a time)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TypeVar, overload

T = TypeVar("T")


class Computed(Sequence[T]):
    """``len`` and :meth:`at` (an index in range) make the sequence: indexing with negative numbers
    and slices, iteration, ``in`` and equality with another sequence follow; ``what`` names an item
    in the IndexError."""

    what = "item"

    def at(self, i: int) -> T:
        raise NotImplementedError

    @overload
    def __getitem__(self, i: int) -> T: ...
    @overload
    def __getitem__(self, i: slice) -> list[T]: ...

    def __getitem__(self, i: int | slice) -> T | list[T]:
        if isinstance(i, slice):
            return [self.at(j) for j in range(*i.indices(len(self)))]
        n = len(self)
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"{self.what} {i} of {n}")
        return self.at(i)

    def __eq__(self, other: object) -> bool:
        return list(self) == list(other) if isinstance(other, Sequence) else NotImplemented

    __hash__ = None  # type: ignore[assignment]
