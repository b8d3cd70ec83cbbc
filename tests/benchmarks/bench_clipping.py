"""Benchmarks for gfxlab.clipping against shapely, measured in the same run."""

from __future__ import annotations

import jax
import numpy as np
import shapely
from harness import Table, timeit

from gfxlab import clipping

WINDOW = (2.0, 2.0, 10.0, 8.0)


def main() -> None:
    table = Table("clipping: 10^6 random segments", reference_name="shapely")
    rng = np.random.default_rng(0)
    segments = rng.uniform(-4.0, 16.0, (1_000_000, 2, 2))
    device_segments = jax.device_put(segments)
    box = shapely.box(*WINDOW)
    lines = shapely.linestrings(segments)

    def reference():
        return shapely.intersection(lines, box)

    ref = timeit(reference, repeat=1, warmup=0)
    ref_total = timeit(
        lambda: shapely.intersection(shapely.linestrings(segments), box), repeat=1, warmup=0
    )
    for name, fn in (
        ("cohen_sutherland", clipping.cohen_sutherland),
        ("liang_barsky", clipping.liang_barsky),
    ):
        jitted = jax.jit(fn)
        ours = timeit(lambda f=jitted: f(device_segments, WINDOW), repeat=5)
        table.add(
            f"{name} (jit), 10^6 segments",
            ours,
            ref,
            "shapely: intersection of prebuilt LineStrings with the box",
        )
    steps = jax.jit(clipping.cohen_sutherland_steps)
    ours = timeit(lambda: steps(device_segments, WINDOW), repeat=3)
    table.add("cohen_sutherland_steps (while_loop, vmapped)", ours, ref)
    cs = jax.jit(clipping.cohen_sutherland)
    ours = timeit(lambda: cs(segments, WINDOW), repeat=5)
    table.add(
        "cohen_sutherland from NumPy input",
        ours,
        ref_total,
        "shapely timed with building the LineStrings",
    )
    table.print()


if __name__ == "__main__":
    main()
