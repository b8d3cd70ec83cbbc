"""Polygon fill: the even-odd inside test (the one owner of it in gfxlab), vectorized
and scan line by scan line."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

from .._checks import check_last_dim, check_shape
from .._pixels import checked_shape, pixel_centers, row_to_y
from ._args import array_arg, finite_arg, float_dtype

__all__ = ["inside_polygon", "fill_polygon", "fill_polygon_scanline"]


def _check_vertices(vertices, name: str = "vertices") -> jax.Array:
    """Finite `(..., V, 2)` vertices with `V >= 3` (kept in their dtype)."""
    vertices = array_arg(vertices, name)
    check_last_dim(vertices, name, (2,), "polygon vertices (x, y)")
    if vertices.ndim < 2 or vertices.shape[-2] < 3:
        raise ValueError(
            f"`{name}` must have shape (..., V, 2) with at least 3 vertices, got shape "
            f"{tuple(vertices.shape)}"
        )
    return finite_arg(vertices, name)


def inside_polygon(
    points: Float[Array, "*batch 2"], vertices: Float[Array, "V 2"]
) -> Bool[Array, "*batch"]:
    """Even-odd point-in-polygon test, vectorized over points and edges.

    A point is inside when a ray from it towards +x crosses the boundary an odd number
    of times. An edge counts when one endpoint is strictly above the point's y and the
    other is not (a half-open rule, so a ray through a vertex counts once).

    **Arguments:**

    - `points`: `(..., 2)` finite query points.
    - `vertices`: `(V, 2)` polygon vertices in order (closed implicitly, either
      orientation, self-intersections allowed), finite.

    **Returns:** boolean `(...)`.

    >>> square = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]
    >>> inside_polygon([[1.0, 1.0], [3.0, 1.0]], square).tolist()
    [True, False]
    """
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    points = array_arg(points, "points")
    check_last_dim(points, "points", (2,), "points (x, y)")
    return _inside_polygon(finite_arg(points, "points"), vertices)


def even_odd(points, vertices):
    """The even-odd test on arrays inside a trace (no checks): points `(..., 2)`,
    vertices `(V, 2)`, both float."""
    a = vertices
    b = jnp.roll(vertices, -1, axis=0)
    px = points[..., None, 0]
    py = points[..., None, 1]
    straddles = (a[:, 1] > py) != (b[:, 1] > py)
    dy = b[:, 1] - a[:, 1]
    safe_dy = jnp.where(straddles, dy, 1.0)
    x_cross = a[:, 0] + (py - a[:, 1]) * (b[:, 0] - a[:, 0]) / safe_dy
    crossings = jnp.sum(straddles & (px < x_cross), axis=-1)
    return crossings % 2 == 1


@jax.jit
def _inside_polygon(points, vertices):
    dtype = jnp.result_type(float_dtype(points), float_dtype(vertices))
    return even_odd(points.astype(dtype), vertices.astype(dtype))


def fill_polygon(vertices: Float[Array, "V 2"], shape: tuple[int, int]) -> Bool[Array, "H W"]:
    """Fill a polygon: the pixels whose centres are inside it (even-odd rule), vectorized.

    **Arguments:**

    - `vertices`: `(V, 2)` vertices in pixel coordinates `(x, y)`, y up.
    - `shape`: the image shape `(H, W)` (static, each side at most `MAX_IMAGE_SIDE`).

    **Returns:** a boolean `(H, W)` mask. `fill_polygon_scanline` gives the same mask
    scan line by scan line.
    """
    shape = checked_shape(shape)
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    return _fill_polygon(vertices, shape)


@jax.jit(static_argnames="shape")
def _fill_polygon(vertices, shape):
    vertices = vertices.astype(float_dtype(vertices))
    return even_odd(pixel_centers(shape, dtype=vertices.dtype), vertices)


def fill_polygon_scanline(
    vertices: Float[Array, "V 2"], shape: tuple[int, int]
) -> Bool[Array, "H W"]:
    """Textbook scan-line polygon fill (`lax.scan` over scan lines).

    For each scan line `y` (a row of pixel centres) intersect every edge that straddles
    it (half-open in y, so a vertex is counted once), sort the crossings and fill the
    pixel centres between crossings 1-2, 3-4, ... (left-closed, right-open).
    Same arguments and result as `fill_polygon`.
    """
    height, width = checked_shape(shape)
    vertices = _check_vertices(vertices)
    check_shape(vertices, "vertices", (None, 2))
    return _fill_polygon_scanline(vertices, (height, width))


@jax.jit(static_argnames="shape")
def _fill_polygon_scanline(vertices, shape):
    height, width = shape
    vertices = vertices.astype(float_dtype(vertices))
    a = vertices
    b = jnp.roll(vertices, -1, axis=0)
    xs = jnp.arange(width, dtype=vertices.dtype)

    def scan_line(_, y):
        straddles = (a[:, 1] > y) != (b[:, 1] > y)
        dy = jnp.where(straddles, b[:, 1] - a[:, 1], 1.0)
        x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / dy
        x_cross = jnp.sort(jnp.where(straddles, x_cross, jnp.inf))
        # A pixel is inside when an odd number of sorted crossings lie at or left of it.
        count = jnp.sum(x_cross[None, :] <= xs[:, None], axis=-1)
        return None, count % 2 == 1

    ys = row_to_y(jnp.arange(height), height).astype(vertices.dtype)
    _, rows = jax.lax.scan(scan_line, None, ys)
    return rows
