"""Per pixel-face geometry, tiles and bins, and the tile capacity.

The image is cut into `tile_size x tile_size` tiles; each tile sees only the faces whose
(margin-grown) bounding box reaches it, at most `capacity` of them. `needed_capacity`
counts the largest number of faces a tile sees, so the capacity can be found from the
geometry before compiling.
"""

from __future__ import annotations

import functools
import math
import warnings

import jax
import jax.numpy as jnp

from .._checks import is_traced, static_int, value_error_if
from .._pixels import pixel_centers


def cross2(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


def pixel_face_terms(points, tri):
    """Squared distance, inside flag and clamped barycentrics of pixels vs triangles.

    `points (P, 2)`, `tri (K, 3, 2)` -> `d2 (P, K)`, `inside (P, K)`, `bary (P, K, 3)`.
    Degenerate triangles are never inside; every value and gradient stays finite.
    Written per coordinate (no trailing axes of size 2 or 3), which XLA runs faster.
    """
    px, py = points[:, 0:1], points[:, 1:2]  # (P, 1)
    cx = [tri[None, :, k, 0] for k in range(3)]  # (1, K) each
    cy = [tri[None, :, k, 1] for k in range(3)]
    d2 = None
    edge_fn = []
    for k in range(3):
        ex, ey = cx[(k + 1) % 3] - cx[k], cy[(k + 1) % 3] - cy[k]
        rx, ry = px - cx[k], py - cy[k]
        length2 = ex * ex + ey * ey
        nonzero = length2 > 0
        t = jnp.where(nonzero, (rx * ex + ry * ey) / jnp.where(nonzero, length2, 1.0), 0.0)
        t = jnp.clip(t, 0.0, 1.0)
        ox, oy = rx - t * ex, ry - t * ey
        dk = ox * ox + oy * oy
        d2 = dk if d2 is None else jnp.minimum(d2, dk)
        edge_fn.append(ex * ry - ey * rx)  # twice the signed area opposite corner k + 2
    area2 = (cx[1] - cx[0]) * (cy[2] - cy[0]) - (cy[1] - cy[0]) * (cx[2] - cx[0])
    proper = area2 != 0
    sign = jnp.sign(area2)
    inside = proper & (edge_fn[0] * sign >= 0) & (edge_fn[1] * sign >= 0) & (edge_fn[2] * sign >= 0)
    safe = jnp.where(proper, area2, 1.0)
    bary = [jnp.clip(edge_fn[(k + 1) % 3] / safe, 0.0, 1.0) for k in range(3)]
    total = jnp.maximum(bary[0] + bary[1] + bary[2], 1e-12)
    bary = jnp.stack([jnp.where(proper, b / total, 1.0 / 3) for b in bary], -1)
    return d2, inside, bary


def logit_limit(eps: float) -> float:
    return math.log(1.0 / eps - 1.0)


def tile_points(shape, tile_size, dtype):
    """Pixel centres `(T, t*t, 2)` of every tile (the image padded to whole tiles)."""
    height, width = shape
    t = tile_size
    rows, cols = -(-height // t), -(-width // t)
    grid = pixel_centers((rows * t, cols * t), dtype)
    grid = grid.at[..., 1].add(height - rows * t)  # the padding lies below the image
    return grid.reshape(rows, t, cols, t, 2).transpose(0, 2, 1, 3, 4).reshape(-1, t * t, 2)


def untile(tiles, shape, tile_size):
    """Inverse of `tile_points` for per-pixel results `(T, t*t, C)` -> `(H, W, C)`."""
    height, width = shape
    t = tile_size
    rows, cols = -(-height // t), -(-width // t)
    image = tiles.reshape(rows, cols, t, t, -1).transpose(0, 2, 1, 3, 4)
    return image.reshape(rows * t, cols * t, -1)[:height, :width]


def _face_boxes(tri, margin):
    return jax.lax.stop_gradient(
        jnp.concatenate([jnp.min(tri, 1) - margin, jnp.max(tri, 1) + margin], -1)
    )  # (F, 4): xmin, ymin, xmax, ymax


def _overlaps(box, valid, points):
    lo, hi = jnp.min(points, 0), jnp.max(points, 0)
    return (
        valid
        & (box[:, 0] <= hi[0])
        & (box[:, 2] >= lo[0])
        & (box[:, 1] <= hi[1])
        & (box[:, 3] >= lo[1])
    )


@functools.partial(jax.jit, static_argnames=("shape", "tile_size"))
def max_tile_count(tri, valid, margin, *, shape, tile_size):
    """The largest number of faces any tile sees (batched over leading axes of `tri`)."""
    points = tile_points(shape, tile_size, tri.dtype)

    def one(tri, valid):
        box = _face_boxes(tri, margin)
        return jnp.max(jax.vmap(lambda p: jnp.sum(_overlaps(box, valid, p)))(points))

    flat_tri = tri.reshape((-1,) + tri.shape[-3:])
    flat_valid = valid.reshape((-1, valid.shape[-1]))
    return jnp.max(jax.lax.map(lambda a: one(*a), (flat_tri, flat_valid)))


#: Under tracing, `capacity=None` gives every tile room for all faces up to this many.
TRACED_ALL_FACES = 256


def round_capacity(count: int, faces: int) -> int:
    """A capacity of at least `count`, rounded up to one of four steps per octave (8, 10,
    12, 14, 16, 20, ...: few recompilations, little waste), at most the number of faces."""
    count = max(count, 1)
    step = max(1, 1 << max(0, count.bit_length() - 3))
    return max(1, min(faces, max(8, -(-count // step) * step)))


def tiled(
    pixel_fn, tri, valid, faces, shape, *, margin, tile_size, capacity, tiles_per_step, binned=True
):
    """Evaluate `pixel_fn(points, faces_subset, slot_mask, ids)` over the image, tile by tile.

    Tiles are processed in steps of `tiles_per_step`, busiest first; a step whose tiles
    see no face at all is skipped (`lax.cond`) and gets the empty-tile value, so the
    cost follows the area the geometry covers. Returns `(image (H, W, ...),
    max_faces_in_a_tile)`.
    """
    points = tile_points(shape, tile_size, tri.dtype)
    box = _face_boxes(tri, margin)
    total = points.shape[0]

    @jax.checkpoint
    def shade(points, ids, slot_mask, faces):
        subset = jax.tree_util.tree_map(lambda a: a[ids], faces)
        return pixel_fn(points, subset, slot_mask, ids)

    def one_tile(points):
        if binned:
            overlap = _overlaps(box, valid, points)
            count = jnp.sum(overlap, dtype=jnp.int32)
            (ids,) = jnp.nonzero(overlap, size=capacity, fill_value=0)
            slot_mask = jnp.arange(capacity) < count
        else:
            ids = jnp.arange(tri.shape[0])
            slot_mask = valid
        return shade(points, ids, slot_mask, faces)

    counts = jax.vmap(lambda p: jnp.sum(_overlaps(box, valid, p), dtype=jnp.int32))(points)
    # the value of a tile without faces (constant over its pixels)
    ids0 = jnp.zeros(1, jnp.int32)
    empty = pixel_fn(
        points[0, :1], jax.tree_util.tree_map(lambda a: a[ids0], faces), jnp.zeros(1, bool), ids0
    )
    order = jnp.argsort(-counts)  # busiest tiles first: empty ones gather in whole steps
    batch = min(tiles_per_step, total)
    steps = -(-total // batch)
    order = jnp.concatenate([order, jnp.repeat(order[-1:], steps * batch - total)])
    order = order.reshape(steps, batch)

    def step(tile_ids):
        def work(tile_ids):
            return jax.vmap(one_tile)(points[tile_ids])

        def skip(tile_ids):
            return jnp.broadcast_to(empty, (batch, points.shape[1]) + empty.shape[1:])

        return jax.lax.cond(counts[tile_ids[0]] > 0, work, skip, tile_ids)

    tiles = jax.lax.map(step, order).reshape((steps * batch, points.shape[1]) + empty.shape[1:])
    inverse = (
        jnp.zeros(total, jnp.int32)
        .at[order.reshape(-1)[:total]]
        .set(jnp.arange(total, dtype=jnp.int32))
    )
    return untile(tiles[inverse], shape, tile_size), jnp.max(counts)


def check_capacity(image, max_count, capacity, tile_size):
    """Under `jax.jit`: a run-time error (naming `capacity`) when a tile overflowed."""
    message = (
        f"a {tile_size}x{tile_size} tile overlaps more faces than `capacity` = {capacity}; "
        "pass a larger `capacity` (gfxlab.render.tile_capacity measures it before "
        "jit), or leave `capacity=None` in an eager call to have it found automatically"
    )
    return value_error_if(image, max_count > capacity, message)


def check_options(sigma, eps, tile_size, capacity, tiles_per_step):
    sigma = value_error_if(sigma, ~(sigma > 0), "`sigma` must be > 0 (in pixels^2)")
    if not isinstance(eps, float | int) or not 0 < eps < 0.5:
        raise ValueError(f"`eps` must be a Python float in (0, 0.5), got {eps!r}")
    tile_size = static_int(tile_size, "tile_size", minimum=1, maximum=256)
    if capacity is not None:
        capacity = static_int(capacity, "capacity", minimum=1)
    tiles_per_step = static_int(tiles_per_step, "tiles_per_step", minimum=1)
    return sigma, tile_size, capacity, tiles_per_step


def resolve_capacity(capacity, tri, valid, margin, shape, tile_size, traced_inputs, faces=None):
    """The capacity to compile with, and whether a run must be checked for overflow.

    `capacity=None`: measured from the geometry (eagerly). Under `jax.jit` the geometry
    is unknown: up to `TRACED_ALL_FACES` faces every tile gets room for all of them,
    beyond that a clear error (at trace time) asks for an explicit capacity. An explicit
    capacity that an eager call overflows is grown, with a warning.
    """
    faces = tri.shape[-3] if faces is None else faces
    if traced_inputs:
        if capacity is None and faces <= TRACED_ALL_FACES:
            return max(faces, 1)  # every face fits in every tile: no overflow possible
        if capacity is None:
            raise ValueError(
                f"`capacity=None` finds the tile capacity from the geometry, which is not "
                f"known under jax.jit/grad/vmap tracing (and {faces} faces are too many to "
                "give every tile room for all): measure it first with "
                "`gfxlab.render.tile_capacity(...)` (outside the traced function) and pass "
                "`capacity=`"
            )
        return capacity
    needed = int(max_tile_count(tri, valid, margin, shape=shape, tile_size=tile_size))
    if capacity is None:
        return round_capacity(needed, faces)
    if needed > capacity:
        grown = round_capacity(needed, faces)
        warnings.warn(
            f"a {tile_size}x{tile_size} tile overlaps {needed} faces, more than `capacity` = "
            f"{capacity}; recompiling with capacity {grown}",
            RuntimeWarning,
            stacklevel=3,
        )
        return grown
    return capacity


def any_traced(*trees) -> bool:
    return any(is_traced(t) for t in trees)
