"""Benchmarks for gfxlab.raster against scikit-image, measured in the same run."""

from __future__ import annotations

import jax
import numpy as np
import skimage.draw
from harness import Table, timeit

from gfxlab import raster


def main() -> None:
    table = Table("raster: scan conversion", reference_name="scikit-image")
    for radius in (10, 100, 1000, 10000):
        ours = timeit(lambda r=radius: raster.midpoint_circle(r, center=(5, 7)), repeat=7)
        ref = timeit(lambda r=radius: skimage.draw.circle_perimeter(7, 5, r), repeat=7)
        count = len(raster.midpoint_circle(radius))
        table.add(f"midpoint_circle r={radius}", ours, ref, f"{count} pixels")
    steps = timeit(lambda: raster.midpoint_circle_steps(1000), repeat=5)
    table.add("midpoint_circle_steps r=1000 (lax.scan)", steps, None, "stepwise version")
    for length in (100, 5000):
        ours = timeit(lambda n=length: raster.line_bresenham((0, 0), (n, n // 3)), repeat=7)
        ref = timeit(lambda n=length: skimage.draw.line(0, 0, n // 3, n), repeat=7)
        table.add(f"line_bresenham length {length}", ours, ref)
    rng = np.random.default_rng(0)
    vertices = rng.uniform(0, 512, (12, 2))
    fill = jax.jit(raster.fill_polygon, static_argnames="shape")
    ours = timeit(lambda: fill(vertices, shape=(512, 512)), repeat=5)
    ref = timeit(
        lambda: skimage.draw.polygon(512 - 1 - vertices[:, 1], vertices[:, 0], (512, 512)), repeat=5
    )
    table.add("fill_polygon 512x512, 12 vertices", ours, ref, "even-odd vs skimage polygon")
    coverage = jax.jit(raster.polygon_coverage, static_argnames="shape")
    ours = timeit(lambda: coverage(vertices / 2, shape=(256, 256)), repeat=5)
    table.add("polygon_coverage 256x256, 12 vertices", ours, None, "exact area, no reference")
    table.print()


if __name__ == "__main__":
    main()
