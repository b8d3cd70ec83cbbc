"""Timing helpers shared by the benchmarks (not collected by pytest).

Every benchmark prints rows of: case, our time, the reference's time measured in the
same run, and the ratio reference/ours (> 1 means we are faster).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import jax


def samples(fn: Callable[[], object], *, repeat: int = 5, warmup: int = 1) -> list[float]:
    """Wall times in seconds of `repeat` calls of `fn()` after `warmup`, blocking on JAX
    results."""
    for _ in range(warmup):
        jax.block_until_ready(fn())
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - start)
    return times


def timeit(fn: Callable[[], object], *, repeat: int = 5, warmup: int = 1) -> float:
    """Median wall time in seconds of `fn()`, blocking on JAX results."""
    return statistics.median(samples(fn, repeat=repeat, warmup=warmup))


def timeit_pair(
    ours: Callable[[], object],
    reference: Callable[[], object],
    *,
    repeat: int = 51,
    warmup: int = 3,
) -> tuple[float, float]:
    """Median wall times in seconds of `ours()` and `reference()`, called alternately so
    that both see the same machine state (on a shared VM, speed drifts by tens of
    percent over seconds; timing one after the other would fold that drift into the
    ratio)."""
    for _ in range(warmup):
        jax.block_until_ready(ours())
        jax.block_until_ready(reference())
    times: tuple[list[float], list[float]] = ([], [])
    for _ in range(repeat):
        for fn, out in zip((ours, reference), times, strict=True):
            start = time.perf_counter()
            jax.block_until_ready(fn())
            out.append(time.perf_counter() - start)
    return statistics.median(times[0]), statistics.median(times[1])


class Table:
    """A printed comparison table."""

    def __init__(self, title: str, reference_name: str = "reference"):
        self.title = title
        self.reference_name = reference_name
        self.rows: list[tuple[str, float, float | None, str]] = []

    def add(self, case: str, ours: float, reference: float | None = None, note: str = "") -> None:
        self.rows.append((case, ours, reference, note))

    def print(self) -> None:
        print(f"\n## {self.title}\n")
        print(f"| case | ours (ms) | {self.reference_name} (ms) | ratio ref/ours | note |")
        print("| --- | ---: | ---: | ---: | --- |")
        for case, ours, ref, note in self.rows:
            ref_s = f"{ref * 1e3:.2f}" if ref is not None else "-"
            ratio = f"{ref / ours:.2f}x" if ref is not None and ours > 0 else "-"
            print(f"| {case} | {ours * 1e3:.2f} | {ref_s} | {ratio} | {note} |")
