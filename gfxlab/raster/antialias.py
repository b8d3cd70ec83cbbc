"""Anti-aliasing: supersampling (the one owner of it in gfxlab) and exact area coverage."""

from __future__ import annotations

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import check_last_dim, static_int
from .._pixels import checked_shape, pixel_centers, subpixel_offsets
from ._args import array_arg, finite_arg, float_dtype, float_scalar
from .polygons import _check_vertices

__all__ = ["MAX_SUPERSAMPLE", "supersample", "polygon_coverage", "line_coverage"]

#: Largest `samples` of `supersample` (samples per pixel along each axis).
MAX_SUPERSAMPLE = 64


def supersample(
    fn: Callable[[jax.Array], jax.Array], shape: tuple[int, int], *, samples: int = 4
) -> Float[Array, "H W"]:
    """Anti-alias by supersampling: average `fn` over a `samples x samples` grid per pixel.

    `fn` is traced once per `(fn, shape, samples)` and the whole computation runs as one
    compiled call, so `fn` must be written with `jax.numpy`.

    **Arguments:**

    - `fn`: maps points `(..., 2)` in pixel coordinates to values `(...)` (booleans
      for an inside test, or intensities).
    - `shape`: the image shape `(H, W)` (static).
    - `samples`: samples per pixel along each axis (static int in `1..MAX_SUPERSAMPLE`);
      the samples sit at the centres of a regular `samples x samples` grid of sub-pixels.

    **Returns:** a float `(H, W)` image: the mean of `fn` over each pixel's samples.

    >>> disc = lambda p: (p[..., 0] - 1.5) ** 2 + (p[..., 1] - 1.5) ** 2 < 1.5**2
    >>> supersample(disc, (4, 4), samples=8).shape
    (4, 4)
    """
    if not callable(fn):
        raise TypeError(f"`fn` must be a function of points (..., 2), got {type(fn).__name__}")
    height, width = checked_shape(shape)
    samples = static_int(samples, "samples", minimum=1, maximum=MAX_SUPERSAMPLE)
    return _supersample(fn, (height, width), samples)


@eqx.filter_jit  # `fn` may be a plain function or a pytree (an `eqx.Module` with arrays)
def _supersample(fn, shape, samples):
    return supersample_values(fn, shape, samples, dtype=jnp.result_type(float))


def supersample_values(fn, shape: tuple[int, int], samples: int, *, dtype, trailing: int = 0):
    """Inside a trace: the mean over each pixel's `samples x samples` samples of
    `fn(points)`, points `(H, W, samples^2, 2)`; `fn` may add `trailing` value axes
    (e.g. an RGB colour), which the result keeps: `(H, W, ...)`."""
    offsets = subpixel_offsets(samples, dtype=dtype)
    samples = pixel_centers(shape, dtype=dtype)[:, :, None, :] + offsets
    values = jnp.asarray(fn(samples))
    expected = samples.shape[:-1]
    if values.shape[:3] != expected or values.ndim != 3 + trailing:
        raise ValueError(
            f"`fn` must map points of shape (..., 2) to values of shape (...), got "
            f"{values.shape} for points of shape {samples.shape}"
        )
    return jnp.mean(values.astype(dtype), axis=2)


def _clamped_integral(x, lo, hi):
    """Antiderivative of `clamp(x, lo, hi) - lo`, zero at `x = lo`."""
    below = x < lo
    above = x > hi
    inner = 0.5 * (x - lo) ** 2
    full = 0.5 * (hi - lo) ** 2 + (hi - lo) * (x - hi)
    return jnp.where(below, 0.0, jnp.where(above, full, inner))


def polygon_coverage(
    vertices: Float[Array, "*batch V 2"], shape: tuple[int, int]
) -> Float[Array, "*batch H W"]:
    """Exact area of each pixel covered by a polygon: analytic anti-aliasing.

    By Green's theorem the area of a polygon inside a box `[x0, x1] x [y0, y1]` is the
    boundary integral of `(clamp(x, x0, x1) - x0) d clamp(y, y0, y1)`; along a straight
    edge that integral has a closed form. Every pixel and every edge are evaluated at
    once. Differentiable in `vertices` (gradients flow through edges crossing pixels).

    **Arguments:**

    - `vertices`: `(..., V, 2)` vertices of a simple polygon (either orientation) in
      pixel coordinates, y up.
    - `shape`: the image shape `(H, W)` (static).

    **Returns:** float `(..., H, W)` coverage in `[0, 1]`.
    """
    shape = checked_shape(shape)
    return _polygon_coverage(_check_vertices(vertices), shape)


@jax.jit(static_argnames="shape")
def _polygon_coverage(vertices, shape):
    return _coverage(vertices.astype(float_dtype(vertices)), shape)


def _coverage(vertices, shape):
    centres = pixel_centers(shape, dtype=vertices.dtype)
    x0 = centres[..., 0][..., None] - 0.5
    y0 = centres[..., 1][..., None] - 0.5
    x1, y1 = x0 + 1.0, y0 + 1.0
    a = vertices[..., None, None, :, :]  # (..., 1, 1, V, 2)
    b = jnp.roll(vertices, -1, axis=-2)[..., None, None, :, :]
    ax, ay, bx, by = a[..., 0], a[..., 1], b[..., 0], b[..., 1]
    dy = by - ay
    flat = jnp.abs(dy) == 0
    safe_dy = jnp.where(flat, 1.0, dy)
    # Clip the edge to the pixel's band of y; a horizontal edge contributes nothing.
    ya = jnp.clip(ay, y0, y1)
    yb = jnp.clip(by, y0, y1)
    xa = ax + (ya - ay) * (bx - ax) / safe_dy
    xb = ax + (yb - ay) * (bx - ax) / safe_dy
    dx = xb - xa
    close = jnp.abs(dx) < 1e-9
    safe_dx = jnp.where(close, 1.0, dx)
    mean_g = jnp.where(
        close,
        jnp.clip(0.5 * (xa + xb), x0, x1) - x0,
        (_clamped_integral(xb, x0, x1) - _clamped_integral(xa, x0, x1)) / safe_dx,
    )
    signed = jnp.sum(jnp.where(flat, 0.0, (yb - ya) * mean_g), axis=-1)
    # Orientation from the shoelace area, so either vertex order gives positive coverage.
    shoelace = jnp.sum(
        vertices[..., 0] * jnp.roll(vertices[..., 1], -1, axis=-1)
        - jnp.roll(vertices[..., 0], -1, axis=-1) * vertices[..., 1],
        axis=-1,
    )
    orientation = jnp.where(shoelace < 0, -1.0, 1.0)[..., None, None]
    return jnp.clip(orientation * signed, 0.0, 1.0)


def line_coverage(
    p0: Float[Array, "*batch 2"],
    p1: Float[Array, "*batch 2"],
    shape: tuple[int, int],
    *,
    width: float = 1.0,
) -> Float[Array, "*batch H W"]:
    """Exact area coverage of a thick line: the `width`-wide rectangle around `p0 -> p1`.

    **Arguments:**

    - `p0`, `p1`: endpoints `(..., 2)` in pixel coordinates (traced, differentiable).
    - `shape`: the image shape `(H, W)` (static).
    - `width`: the line's thickness in pixels (> 0).

    **Returns:** float `(..., H, W)` coverage in `[0, 1]`.
    """
    p0 = finite_arg(array_arg(p0, "p0"), "p0")
    p1 = finite_arg(array_arg(p1, "p1"), "p1")
    check_last_dim(p0, "p0", (2,), "a point (x, y)")
    check_last_dim(p1, "p1", (2,), "a point (x, y)")
    width = float_scalar(width, "width", low=0)
    return _line_coverage(p0, p1, width, checked_shape(shape))


@jax.jit(static_argnames="shape")
def _line_coverage(p0, p1, width, shape):
    dtype = jnp.result_type(float_dtype(p0), float_dtype(p1))
    p0, p1 = p0.astype(dtype), p1.astype(dtype)
    width = jnp.asarray(width, dtype)
    d = p1 - p0
    length_sq = jnp.sum(d * d, axis=-1, keepdims=True)
    positive = length_sq > 0
    length = jnp.sqrt(jnp.where(positive, length_sq, 1.0))
    direction = jnp.where(positive, d / length, jnp.array([1.0, 0.0], d.dtype))
    normal = jnp.stack([-direction[..., 1], direction[..., 0]], -1) * (0.5 * width)
    rect = jnp.stack([p0 - normal, p1 - normal, p1 + normal, p0 + normal], axis=-2)
    return _coverage(rect, shape)
