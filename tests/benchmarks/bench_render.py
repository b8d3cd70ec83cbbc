"""Soft rasterizer: binned tiles vs the dense reference, face-count scaling, memory.

`python tests/benchmarks/run.py render`. Scenes are random small triangles facing the
camera (float32), rendered with `soft_rasterize` (colour, depth, silhouette) and
differentiated with respect to the vertices (forward + backward).
"""

from __future__ import annotations

import math
import time

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit

from gfxlab import render as R
from gfxlab.mesh import Mesh
from gfxlab.viewing import Camera

SIGMA, GAMMA, EPS = 1.0, 0.05, 1e-4


def scene(faces: int, size: int, coverage: float = 0.5, seed: int = 0):
    """`faces` random triangles of equal area covering `coverage` of the screen in total."""
    rng = np.random.default_rng(seed)
    camera = Camera(jnp.array([0.0, 0.0, 4.0]), fov_y=0.5, near=1.0, far=10.0)
    half = 4.0 * math.tan(0.25)  # half the visible width at z = 0
    area = coverage * (2 * half) ** 2 / faces
    radius = math.sqrt(area / (0.75 * math.sqrt(3)))  # equilateral triangle of that area
    angle = rng.uniform(0, 2 * np.pi, (faces, 1)) + np.array([0, 2, 4]) * np.pi / 3
    centre = rng.uniform(-half, half, (faces, 1, 2))
    xy = centre + radius * np.stack([np.cos(angle), np.sin(angle)], -1)
    z = rng.uniform(-0.5, 0.5, (faces, 1, 1)) * np.ones((1, 3, 1))
    vertices = np.concatenate([xy, z], -1).reshape(-1, 3).astype(np.float32)
    colors = rng.uniform(0, 1, vertices.shape).astype(np.float32)
    mesh = Mesh(jnp.asarray(vertices), jnp.arange(3 * faces).reshape(faces, 3), colors)
    return mesh, camera


def needed_capacity(mesh, camera, shape, tile_size):
    """The largest number of faces any tile sees (as the binning counts it)."""
    tri = np.asarray(camera.to_pixels(mesh.vertices, shape))[np.asarray(mesh.faces)]
    margin = math.sqrt(SIGMA * math.log(1 / EPS - 1))
    lo, hi = tri.min(1) - margin, tri.max(1) + margin
    h, w = shape
    # tile index ranges of every face (columns from x; rows from y = h - 1 - row)
    c0, c1 = np.floor(lo[:, 0] / tile_size), np.floor(hi[:, 0] / tile_size)
    r0, r1 = np.floor((h - 1 - hi[:, 1]) / tile_size), np.floor((h - 1 - lo[:, 1]) / tile_size)
    rows, cols = -(-h // tile_size), -(-w // tile_size)
    c0, c1 = np.clip(c0, 0, cols - 1).astype(int), np.clip(c1, -1, cols - 1).astype(int)
    r0, r1 = np.clip(r0, 0, rows - 1).astype(int), np.clip(r1, -1, rows - 1).astype(int)
    keep = (c1 >= c0) & (r1 >= r0)
    counts = np.zeros((rows + 1, cols + 1), int)  # 2D difference array of the tile ranges
    for dr, dc, sign in ((r0, c0, 1), (r0, c1 + 1, -1), (r1 + 1, c0, -1), (r1 + 1, c1 + 1, 1)):
        np.add.at(counts, (dr[keep], dc[keep]), sign)
    counts = counts.cumsum(0).cumsum(1)[:rows, :cols]
    return int(counts.max())


def value_and_grad(mesh, camera, shape, *, tile_size, capacity, binned=True, tiles_per_step=16):
    """A jitted forward + backward of a loss on the rendered image (vertices)."""
    tri, inv, col, valid = R._project_mesh(mesh, camera, shape, None, 0.3)
    dtype = tri.dtype
    params = (
        jnp.asarray(SIGMA, dtype),
        jnp.asarray(GAMMA, dtype),
        camera.near.astype(dtype),
        camera.far.astype(dtype),
        jnp.zeros(3, dtype),
        jnp.asarray(1e-3, dtype),
    )

    def loss(vertices):
        m = Mesh(vertices, mesh.faces, mesh.colors)
        tri, inv, col, valid = R._project_mesh(m, camera, shape, None, 0.3)
        out, _ = R._color_core(
            tri,
            inv,
            col,
            valid,
            params,
            shape=shape,
            eps=EPS,
            tile_size=tile_size,
            capacity=capacity,
            tiles_per_step=tiles_per_step,
            binned=binned,
        )
        return jnp.mean(out[..., :3]) + jnp.mean(out[..., 3])

    del tri, inv, col, valid
    return jax.jit(jax.value_and_grad(loss)), mesh.vertices


def main() -> None:
    shape = (256, 256)
    tile = 16
    mesh, camera = scene(10_000, 256)
    scaling = Table("equal screen coverage (50 %), 256x256, same tile and capacity", "10,000 faces")
    many, camera = scene(100_000, 256)
    capacity = max(needed_capacity(many, camera, shape, 8), needed_capacity(mesh, camera, shape, 8))
    capacity = 32 * -(-capacity // 32)
    few_fn, v_few = value_and_grad(mesh, camera, shape, tile_size=8, capacity=capacity)
    many_fn, v_many = value_and_grad(many, camera, shape, tile_size=8, capacity=capacity)
    t_few = timeit(lambda: few_fn(v_few), repeat=3)
    t_many = timeit(lambda: many_fn(v_many), repeat=3)
    print(f"10k: {t_few * 1e3:.0f} ms, 100k: {t_many * 1e3:.0f} ms", flush=True)
    scaling.add(
        "100,000 faces vs 10,000 faces",
        t_many,
        t_few,
        f"tile 8, capacity {capacity}; cost ratio {t_many / t_few:.2f}x (asked <= 2x)",
    )
    scaling.print()

    print("\n## memory, 1024x1024, 10,000 faces (forward + backward, compiled)\n")
    big = (1024, 1024)
    mesh_big, camera = scene(10_000, 1024)
    capacity = 32 * -(-needed_capacity(mesh_big, camera, big, 16) // 32)
    fn, v = value_and_grad(mesh_big, camera, big, tile_size=16, capacity=capacity)
    stats = fn.lower(v).compile().memory_analysis()
    if stats is None:
        print("memory analysis not available on this backend")
    else:
        total = (
            stats.temp_size_in_bytes + stats.argument_size_in_bytes + (stats.output_size_in_bytes)
        )
        print(
            f"capacity {capacity}: temporaries {stats.temp_size_in_bytes / 2**20:.1f} MiB, "
            f"arguments {stats.argument_size_in_bytes / 2**20:.1f} MiB, outputs "
            f"{stats.output_size_in_bytes / 2**20:.1f} MiB, total {total / 2**20:.1f} MiB"
        )
        t_big = timeit(lambda: fn(v), repeat=1)
        print(f"time {t_big * 1e3:.0f} ms")

    table = Table("soft_rasterize forward + backward, 256x256", "dense reference")
    capacity = needed_capacity(mesh, camera, shape, tile)
    capacity = 32 * -(-capacity // 32)
    fn, v = value_and_grad(mesh, camera, shape, tile_size=tile, capacity=capacity)
    ours = timeit(lambda: fn(v), repeat=3)
    print(f"binned: {ours * 1e3:.0f} ms (capacity {capacity})", flush=True)
    dense_fn, _ = value_and_grad(
        mesh, camera, shape, tile_size=tile, capacity=10_000, binned=False, tiles_per_step=1
    )
    dense_fn = dense_fn.lower(v).compile()  # compile first: time one run, it is slow
    start = time.perf_counter()
    ref_value, ref_grad = jax.block_until_ready(dense_fn(v))
    reference = time.perf_counter() - start
    value, grad = fn(v)
    err = float(jnp.max(jnp.abs(grad - ref_grad)) / jnp.max(jnp.abs(ref_grad)))
    table.add(
        "10,000 faces, binned vs all faces per tile",
        ours,
        reference,
        f"tile {tile}, capacity {capacity}; |value diff| "
        f"{abs(float(value - ref_value)):.1e}, max grad diff / max grad {err:.1e}",
    )
    table.print()
    print(flush=True)


if __name__ == "__main__":
    main()
