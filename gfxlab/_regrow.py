"""Static sizes that a compiled program can outgrow while it runs.

A compiled function has static sizes (a render's tile capacity) that it cannot change
while it runs. When one is exceeded, the function `report`s the size it needs from a
host callback and then raises. A driver that can rerun the computation (`gfxlab.fit`)
calls `grow_reported()`: every reported size is grown and `generation()` moves on, so a
driver that keys its compiled code on the generation retraces, the traced function
asks `grown()` for its sizes, and the rerun has room.
"""

from __future__ import annotations

__all__ = ["clear_reports", "generation", "grow_reported", "grown", "report"]

#: (kind, compiled size) -> the size to compile with instead.
_GROWN: dict[tuple[str, int], int] = {}
#: (kind, compiled size, needed size, what) reported since the last `clear_reports`.
_REPORTED: list[tuple[str, int, int, str]] = []
_GENERATION = [0]


def grown(kind: str, size: int) -> int:
    """`size` after every growth recorded for it (itself when none)."""
    seen = set()
    while (kind, size) in _GROWN and size not in seen:
        seen.add(size)
        size = _GROWN[(kind, size)]
    return size


def report(kind: str, size: int, needed: int, what: str) -> None:
    """Record, from a host callback, that a program compiled with `size` needed
    `needed`; `what` names the size for the warning (e.g. "tile capacity")."""
    _REPORTED.append((kind, int(size), int(needed), what))


def clear_reports() -> None:
    """Forget the reports so far (a driver calls it before each run)."""
    _REPORTED.clear()


def grow_reported() -> list[str]:
    """Grow every size reported since `clear_reports` and move the generation on;
    returns one line per growth for the driver's warning (empty: nothing to grow)."""
    lines = []
    for kind, size, needed, what in _REPORTED:
        if needed > grown(kind, size):
            _GROWN[(kind, size)] = needed
            lines.append(f"{what} {size} was exceeded; recompiled with {needed}")
    _REPORTED.clear()
    if lines:
        _GENERATION[0] += 1
    return lines


def generation() -> int:
    """A counter that moves on at every growth: part of a driver's compile key."""
    return _GENERATION[0]
