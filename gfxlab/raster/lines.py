"""Lines on the pixel grid: DDA and Bresenham, vectorized and step by step.

The endpoints are static (they fix how many pixels come out): the vectorized closed
forms run in NumPy at trace time (a constant under `jit`, no compilation per length);
the `*_steps` versions run the textbook recurrence with `lax.scan`, one compiled call
per line length.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Int

from .._checks import check_last_dim, static_int
from .._pixels import checked_shape, pixel_to_index
from ._args import array_arg

__all__ = [
    "MAX_LINE_COORDINATE",
    "points_to_image",
    "line_dda",
    "line_dda_steps",
    "line_bresenham",
    "line_bresenham_steps",
]

#: Largest `|x|` or `|y|` of a line endpoint (a documented size limit): a line has at
#: most `2 * 16383 + 1` pixels, and the stepwise versions' exact int32 arithmetic
#: (`2 dmajor^2 + dmajor < 2^31`) holds.
MAX_LINE_COORDINATE = 16383

_INT = jnp.int32


def points_to_image(points: Int[Array, "*batch N 2"], shape: tuple[int, int]) -> Bool[Array, "H W"]:
    """Plot integer pixel positions `(x, y)` into a boolean `(H, W)` image.

    Points outside the image are dropped; leading batch dimensions are merged.

    **Arguments:**

    - `points`: integer pixel positions, shape `(..., N, 2)`.
    - `shape`: the image shape `(H, W)` (static, each side at most `MAX_IMAGE_SIDE`).

    **Returns:** a boolean mask with `True` at every plotted pixel.
    """
    height, width = checked_shape(shape)
    points = array_arg(points, "points", "an integer array of pixel positions")
    check_last_dim(points, "points", (2,), "pixel positions (x, y)")
    if not jnp.issubdtype(points.dtype, jnp.integer):
        raise TypeError(f"`points` must be integer pixel positions, got dtype {points.dtype}")
    return _points_to_image(points, (height, width))


@jax.jit(static_argnames="shape")
def _points_to_image(points, shape):
    height, width = shape
    points = points.reshape(-1, 2)
    rc = pixel_to_index(points, (height, width))
    inside = (rc[:, 0] >= 0) & (rc[:, 0] < height) & (rc[:, 1] >= 0) & (rc[:, 1] < width)
    # Send outside points out of bounds on the positive side, where `mode="drop"` drops
    # them (negative indices would wrap around).
    rows = jnp.where(inside, rc[:, 0], height)
    cols = jnp.where(inside, rc[:, 1], width)
    return jnp.zeros((height, width), bool).at[rows, cols].set(True, mode="drop")


def _static_point(p, name: str) -> tuple[int, int]:
    if p is None:
        raise TypeError(f"`{name}` must be a pair of ints (x, y), got None")
    if isinstance(p, jax.core.Tracer):
        raise TypeError(
            f"`{name}` fixes how many pixels the line has, so it must be static: a pair of "
            "Python ints, not a traced array"
        )
    try:
        items = list(np.asarray(p).tolist()) if not isinstance(p, tuple | list) else list(p)
    except TypeError as err:
        raise TypeError(f"`{name}` must be a pair of ints (x, y), got {p!r}") from err
    if len(items) != 2:
        raise ValueError(f"`{name}` must be a pair of ints (x, y), got {p!r}")
    lim = MAX_LINE_COORDINATE
    return (
        static_int(items[0], f"{name}[0]", minimum=-lim, maximum=lim),
        static_int(items[1], f"{name}[1]", minimum=-lim, maximum=lim),
    )


def _line_setup(p0, p1):
    """Static description of a line: major axis, step counts and signs."""
    x0, y0 = _static_point(p0, "p0")
    x1, y1 = _static_point(p1, "p1")
    dx, dy = x1 - x0, y1 - y0
    x_major = abs(dx) >= abs(dy)
    d_major, d_minor = (abs(dx), abs(dy)) if x_major else (abs(dy), abs(dx))
    s_major = 1 if (dx if x_major else dy) >= 0 else -1
    s_minor = 1 if (dy if x_major else dx) >= 0 else -1
    return (x0, y0), x_major, d_major, d_minor, s_major, s_minor


def _assemble_line(start, x_major, major_offset, minor_offset):
    """`(N, 2)` pixels from offsets along the major and minor axes (NumPy or traced)."""
    xp = np if isinstance(major_offset, np.ndarray) else jnp
    x0, y0 = start
    if x_major:
        xy = xp.stack([x0 + major_offset, y0 + minor_offset], axis=-1)
    else:
        xy = xp.stack([x0 + minor_offset, y0 + major_offset], axis=-1)
    return jax.device_put(xy.astype(np.int32)) if xp is np else xy.astype(_INT)


def _dda_offsets(d_major, d_minor, k, xp=jnp):
    """DDA minor offsets after `k` major steps: `k dminor / dmajor` rounded half up.

    The float quotient of two small integers is exact at every half-way point, so ties
    always round away from the start.
    """
    dtype = np.float64 if xp is np else jnp.result_type(float)
    frac = (k * d_minor).astype(dtype) / xp.maximum(d_major, 1)
    return xp.floor(frac + 0.5).astype(k.dtype)


def _bresenham_offsets(d_major, d_minor, k):
    """Bresenham minor offsets after `k` major steps (closed form of the recurrence)."""
    return (2 * k * d_minor + d_major) // np.maximum(2 * d_major, 1)


def _round_half_up(numerator, denom):
    """`floor(numerator / denom + 1/2)` for integers, exactly: `(2 n + d) // (2 d)`."""
    return (2 * numerator + denom) // (2 * denom)


def _run_scan(scan, setup):
    """Call a jitted stepwise line: static length and axis, traced start, slope, signs."""
    start, x_major, d_major, d_minor, s_major, s_minor = setup
    values = np.array([*start, d_minor, s_major, s_minor], np.int32)
    return scan(values, length=d_major + 1, x_major=x_major)


@jax.jit(static_argnames=("length", "x_major"))  # compiled once per length and axis
def _dda_scan(values, *, length: int, x_major: bool):
    """Stepwise DDA along (major, minor): per step add the increments, then round.

    The increments `1` and `dminor / dmajor` are kept as exact fixed-point numerators
    over `dmajor` (an integer add per step), so no round-off accumulates.
    """
    x0, y0, d_minor, s_major, s_minor = values
    d_major = length - 1
    denom = max(d_major, 1)

    def step(carry, _):
        major_num, minor_num = carry  # positions times `denom`
        major = _round_half_up(major_num, denom)
        minor = _round_half_up(minor_num, denom)
        return (major_num + d_major, minor_num + d_minor), (major, minor)

    init = (jnp.asarray(0, _INT), jnp.asarray(0, _INT))
    _, (major, minor) = jax.lax.scan(step, init, None, length=length)
    return _assemble_line((x0, y0), x_major, s_major * major, s_minor * minor)


@jax.jit(static_argnames=("length", "x_major"))  # compiled once per length and axis
def _bresenham_scan(values, *, length: int, x_major: bool):
    """Textbook Bresenham along (major, minor) with the integer decision parameter."""
    x0, y0, d_minor, s_major, s_minor = values
    d_major = length - 1

    def step(carry, _):
        major, minor, p = carry
        up = p >= 0
        next_minor = jnp.where(up, minor + 1, minor)
        next_p = jnp.where(up, p - 2 * d_major, p) + 2 * d_minor
        return (major + 1, next_minor, next_p), (major, minor)

    init = (
        jnp.asarray(0, _INT),
        jnp.asarray(0, _INT),
        (2 * d_minor - d_major).astype(_INT),
    )
    _, (major, minor) = jax.lax.scan(step, init, None, length=length)
    return _assemble_line((x0, y0), x_major, s_major * major, s_minor * minor)


def line_dda(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Digital differential analyser (DDA) line from `p0` to `p1`, vectorized.

    Steps one pixel at a time along the major axis (the one with the larger change)
    and moves `dminor / dmajor` along the other, rounding to the nearest pixel; an
    exact tie (a half-way point) rounds away from `p0`, so the result equals
    Bresenham's line (and `skimage.draw.line`) pixel for pixel. The endpoints are
    static, so the pixels are a constant of the trace, computed in NumPy.

    **Arguments:**

    - `p0`, `p1`: integer endpoints `(x, y)` as Python ints (static), each coordinate
      in `[-MAX_LINE_COORDINATE, MAX_LINE_COORDINATE]`.

    **Returns:** int32 `(N, 2)` pixel positions `(x, y)` from `p0` to `p1`, both
    included, `N = max(|dx|, |dy|) + 1`.

    >>> line_dda((0, 0), (4, 2)).tolist()
    [[0, 0], [1, 1], [2, 1], [3, 2], [4, 2]]
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    k = np.arange(d_major + 1, dtype=np.int64)
    minor = _dda_offsets(d_major, d_minor, k, np)
    return _assemble_line(start, x_major, s_major * k, s_minor * minor)


def line_dda_steps(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Stepwise DDA (`lax.scan`): `x += x_inc; y += y_inc; plot(round(x), round(y))`.

    The increments `dx / steps`, `dy / steps` are added once per step. They are kept
    as exact fixed-point numerators over `steps` (an integer add per step), so no
    floating-point round-off accumulates and ties round as in `line_dda`.
    Same arguments and result as `line_dda`.
    """
    return _run_scan(_dda_scan, _line_setup(p0, p1))


def line_bresenham(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Bresenham's integer line from `p0` to `p1`, vectorized, all octants.

    After `k` steps along the major axis, Bresenham's decision parameter has moved the
    minor coordinate `floor((2 k dminor + dmajor) / (2 dmajor))` pixels: the closed
    form of its integer recurrence (`line_bresenham_steps`). A decision parameter of
    exactly zero steps the minor coordinate, as in the textbook (`p_k < 0` keeps it).
    The endpoints are static, so the pixels are a constant of the trace (NumPy).

    **Arguments:**

    - `p0`, `p1`: integer endpoints `(x, y)` as Python ints (static), each coordinate
      in `[-MAX_LINE_COORDINATE, MAX_LINE_COORDINATE]`.

    **Returns:** int32 `(N, 2)` pixel positions `(x, y)` from `p0` to `p1`, both
    included, `N = max(|dx|, |dy|) + 1`.

    >>> line_bresenham((0, 0), (2, 5)).tolist()
    [[0, 0], [0, 1], [1, 2], [1, 3], [2, 4], [2, 5]]
    """
    start, x_major, d_major, d_minor, s_major, s_minor = _line_setup(p0, p1)
    k = np.arange(d_major + 1, dtype=np.int64)
    minor = _bresenham_offsets(d_major, d_minor, k)
    return _assemble_line(start, x_major, s_major * k, s_minor * minor)


def line_bresenham_steps(p0: tuple[int, int], p1: tuple[int, int]) -> Int[Array, "N 2"]:
    """Textbook Bresenham (`lax.scan`) with the integer decision parameter.

    `p_0 = 2 dminor - dmajor`; at each step plot the pixel, then if `p_k >= 0` step the
    minor coordinate and `p -= 2 dmajor`; step the major coordinate and
    `p += 2 dminor`. Same arguments and result as `line_bresenham`.
    """
    return _run_scan(_bresenham_scan, _line_setup(p0, p1))
