"""Filters: the median filter (a pruned selection network on shifted views, never a
sort of every window) and the linear mean and Gaussian filters to contrast it with.

Every filter matches `scipy.ndimage` for every border mode. Called eagerly, each is
one compiled call (compiled once per image shape, dtype, window and mode); the border
value `cval` and a Gaussian's `sigma` are traced.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Shaped

from .._checks import checked_jit, is_traced, static_int
from ..raster._args import array_arg, finite_arg, float_dtype, float_scalar, range_check
from .networks import (
    MAX_NETWORK_SIZE,
    _combine_middle,
    _middle_ranks,
    _run_network,
    _selection_network,
    guard_finite,
)

__all__ = [
    "MODES",
    "MAX_KERNEL_RADIUS",
    "median_filter",
    "mean_filter",
    "gaussian_filter",
    "cross_footprint",
]

#: Border modes of the filters, named as in `scipy.ndimage` (for a row `a b c d`):
#: reflect `b a | a b c d | d c`, mirror `c b | a b c d | c b`, nearest `a a | a b c d | d d`,
#: wrap `c d | a b c d | a b`, constant `k k | a b c d | k k` with `k = cval`.
MODES = ("reflect", "constant", "nearest", "mirror", "wrap")
_NUMPY_PAD_MODE = {
    "reflect": "symmetric",
    "mirror": "reflect",
    "nearest": "edge",
    "wrap": "wrap",
    "constant": "constant",
}

#: Largest kernel radius of the linear filters (a documented size limit): windows of
#: `mean_filter` are at most `2 * 128 + 1` pixels a side, and `gaussian_filter` refuses
#: a `sigma`, `truncate` or `radius` that gives a longer kernel.
MAX_KERNEL_RADIUS = 128


def _check_filter_image(image, name: str = "image") -> jax.Array:
    """An `(H, W)` or `(H, W, C)` real image as a JAX array (no computation)."""
    arr = array_arg(image, name, "an image array (H, W) or (H, W, C)")
    if arr.ndim not in (2, 3) or 0 in arr.shape:
        raise ValueError(
            f"`{name}` must have shape (H, W) or (H, W, C) with no empty axis, got shape "
            f"{arr.shape}"
        )
    return arr


def _check_cval(cval, image: jax.Array):
    """The border value of `mode="constant"`: a finite real scalar (may be traced); a
    Python number becomes a float, so ints and floats share one compiled program.
    A concrete value is checked here, on the host; a traced one (checked even where
    the mode ignores it) inside the filter's compiled call (`guard_cval=True`)."""
    cval = float_scalar(cval, "cval")
    return float(cval) if isinstance(cval, int | float) else cval


def _check_mode(mode) -> str:
    if not isinstance(mode, str) or mode not in MODES:
        raise ValueError(f"`mode` must be one of {MODES}, got {mode!r}")
    return mode


def _guard_image(out, image, cval):
    """`out` after the value checks of every filter on its `image` and `cval`, run inside
    the filter's one compiled call (attached to the result, the last operation). `cval`
    is `None` where it was checked on the host (`_check_cval`): tying the output to a
    scalar's check costs a quarter of a 1024^2 median."""
    out = guard_finite(out, image, "image")
    return out if cval is None else guard_finite(out, cval, "cval")


def _window_size(size, maximum: int) -> tuple[int, int]:
    if size is None:
        raise TypeError("`size` must be an int or a pair (rows, cols), got None")
    if isinstance(size, Sequence) and not isinstance(size, str):
        if len(size) != 2:
            raise ValueError(f"`size` must be an int or a pair (rows, cols), got {size!r}")
        return (
            static_int(size[0], "size[0]", minimum=1, maximum=maximum),
            static_int(size[1], "size[1]", minimum=1, maximum=maximum),
        )
    k = static_int(size, "size", minimum=1, maximum=maximum)
    return k, k


def _pad(image: jax.Array, window: tuple[int, int], mode: str, cval) -> jax.Array:
    """Pad the last two axes (rows, columns) so that a `window` centred as in scipy
    (offsets `-(k // 2) .. k - 1 - k // 2`) stays inside."""
    widths = [(0, 0)] * (image.ndim - 2) + [(k // 2, k - 1 - k // 2) for k in window]
    if mode == "constant":
        return jnp.pad(
            image, widths, mode="constant", constant_values=jnp.asarray(cval).astype(image.dtype)
        )
    return jnp.pad(image, widths, mode=_NUMPY_PAD_MODE[mode])


def cross_footprint(radius: int = 1) -> np.ndarray:
    """The plus-shaped footprint: `radius=1` is the 5-pixel cross of the exam.

    **Returns:** a boolean `(2r + 1, 2r + 1)` array, True on the middle row and column.
    """
    r = static_int(radius, "radius", minimum=0, maximum=MAX_NETWORK_SIZE // 4)
    fp = np.zeros((2 * r + 1, 2 * r + 1), dtype=bool)
    fp[r, :] = fp[:, r] = True
    return fp


def _check_footprint(footprint) -> np.ndarray:
    if footprint is None:
        raise TypeError("`footprint` must be a boolean array")
    if isinstance(footprint, jax.core.Tracer):
        raise TypeError("`footprint` sets the window, so it must be a concrete array, not traced")
    fp = np.asarray(footprint)
    if fp.dtype != np.bool_:
        raise TypeError(f"`footprint` must be a boolean array, got dtype {fp.dtype}")
    if fp.ndim != 2:
        raise ValueError(f"`footprint` must be 2-D (rows, cols), got shape {fp.shape}")
    if not fp.any():
        raise ValueError("`footprint` must select at least one pixel (it is all False)")
    if fp.sum() > MAX_NETWORK_SIZE:
        raise ValueError(
            f"`footprint` must select at most {MAX_NETWORK_SIZE} pixels (a documented size "
            f"limit), got {int(fp.sum())}"
        )
    return fp


@functools.cache
def _rectangle_plan(kh: int, kw: int, ranks: tuple[int, ...]):
    """Plan for ranks of a full `kh x kw` window via sorted columns and rows.

    Sort each column (shared by the `kw` windows that contain it), then the rows of the
    column-sorted window: the result is sorted along both axes, so entry `(i, j)` has at
    least `(i + 1)(j + 1) - 1` entries below it and `(kh - i)(kw - j) - 1` above. Entries
    that cannot hold a wanted rank are dropped; the survivors go through a small network.
    """
    n = kh * kw
    lo, hi = min(ranks), max(ranks)
    survivors, below = [], 0
    for i in range(kh):
        for j in range(kw):
            if (i + 1) * (j + 1) - 1 > hi:
                continue
            if n - (kh - i) * (kw - j) < lo:
                below += 1
                continue
            survivors.append((i, j))
    column_ranks = tuple(sorted({i for i, _ in survivors}))
    row_ranks = {i: tuple(sorted(j for ii, j in survivors if ii == i)) for i in column_ranks}
    column_ops = _selection_network(kh, column_ranks)
    row_ops = {i: _selection_network(kw, r) for i, r in row_ranks.items()}
    final_ranks = tuple(r - below for r in ranks)
    final_ops = _selection_network(len(survivors), final_ranks)
    return survivors, column_ranks, column_ops, row_ops, final_ranks, final_ops


def _window_ranks(padded, shape_hw, footprint: np.ndarray, ranks: tuple[int, ...]) -> list:
    """Order statistics `ranks` over the `footprint` window at every pixel of `padded`."""
    height, width = shape_hw
    kh, kw = footprint.shape
    if footprint.all() and kh * kw > 1:
        survivors, column_ranks, column_ops, row_ops, final_ranks, final_ops = _rectangle_plan(
            kh, kw, ranks
        )
        columns = _run_network(column_ops, [padded[..., r : r + height, :] for r in range(kh)])
        columns = [columns[i] for i in column_ranks]
        columns = dict(zip(column_ranks, jax.lax.optimization_barrier(columns), strict=True))
        # Rows: run each needed row network once and pick the survivors from it.
        sorted_rows = {
            i: _run_network(row_ops[i], [columns[i][..., c : c + width] for c in range(kw)])
            for i in column_ranks
        }
        wires = [sorted_rows[i][j] for i, j in survivors]
        wires = _run_network(final_ops, wires)
        return [wires[r] for r in final_ranks]
    offsets = np.argwhere(footprint)
    views = [padded[..., r : r + height, c : c + width] for r, c in offsets]
    wires = _run_network(_selection_network(len(views), ranks), views)
    return [wires[r] for r in ranks]


def median_filter(
    image: Shaped[Array, "H W *C"],
    *,
    size: int | tuple[int, int] = 3,
    footprint: np.ndarray | None = None,
    mode: str = "reflect",
    cval: float = 0.0,
) -> Shaped[Array, "H W *C"]:
    """Median filter: every pixel becomes the median of its window (per channel).

    Matches `scipy.ndimage.median_filter(image, size=..., footprint=..., mode=..., cval=...)`
    exactly for windows with an odd number of pixels, integer and float images alike
    (same window placement: offsets `-(k // 2) .. k - 1 - k // 2` along each axis). For an
    even number `2K` of pixels the output is the mean of the K-th and (K+1)-th smallest
    values (the exam's rule; SciPy instead returns the (K+1)-th): a float image, since the
    mean of two integers can be a half-integer (round it yourself if you need integers).

    It is computed with a pruned compare-exchange network on shifted views of the padded
    image, never a sort of every window. Full rectangles first sort each column (shared by
    neighbouring windows), then the rows, then select among the few entries that can still
    be the median (for 3x3: `med3(max of lows, med3 of middles, min of highs)`). The
    gradient flows to the selected pixel (split in half at exact ties).

    **Arguments:**

    - `image`: `(H, W)` or `(H, W, C)`, any real dtype.
    - `size`: window size, an int (square) or `(rows, cols)`; ignored if `footprint` is
      given. At most `MAX_NETWORK_SIZE` pixels (a documented limit: the network is
      unrolled into the compiled program).
    - `footprint`: a boolean `(rows, cols)` array selecting the window pixels, e.g.
      `cross_footprint()` (the 5-pixel cross).
    - `mode`: border handling, one of `MODES`: "reflect", "constant", "nearest", "mirror",
      "wrap" (as in `scipy.ndimage`).
    - `cval`: the value outside the image for `mode="constant"` (finite; may be traced).
      For an integer image it is clamped to the dtype's range (`cval=300` on uint8 is
      255), where SciPy wraps it as a C cast does (300 becomes 44): a deliberate
      difference.

    **Returns:**

    The filtered image, same shape; same dtype for odd windows, float for even windows.

    >>> img = np.array([[91, 55, 90], [77, 68, 95], [115, 151, 210]], dtype=np.uint8)
    >>> int(median_filter(img, size=3)[1, 1])  # the exam's 3x3 example
    91
    """
    image = _check_filter_image(image)
    mode = _check_mode(mode)
    cval = _check_cval(cval, image)
    if footprint is None:
        kh, kw = _window_size(size, MAX_NETWORK_SIZE)
        if kh * kw > MAX_NETWORK_SIZE:
            raise ValueError(
                f"`size` must give a window of at most {MAX_NETWORK_SIZE} pixels (a documented "
                f"size limit), got {kh} x {kw}"
            )
        key = _full_window(kh, kw)
    else:
        key = tuple(map(tuple, _check_footprint(footprint).tolist()))
    return _median_filter(image, cval, footprint=key, mode=mode, guard_cval=is_traced(cval))


@functools.cache
def _full_window(kh: int, kw: int) -> tuple[tuple[bool, ...], ...]:
    """The static footprint of a full `kh x kw` window: one object per size, which the
    jit cache matches by identity (a new nested tuple each call costs ~15 us)."""
    return tuple(tuple(row) for row in np.ones((kh, kw), dtype=bool).tolist())


@functools.partial(checked_jit, static_argnames=("footprint", "mode", "guard_cval"))
def _median_filter(image, cval, *, footprint, mode, guard_cval):
    footprint = np.array(footprint, dtype=bool)
    ranks = _middle_ranks(int(footprint.sum()))
    # Channels first, so that shifted views run along contiguous rows.
    planes = jnp.moveaxis(image, -1, 0) if image.ndim == 3 else image
    padded = _pad(planes, footprint.shape, mode, cval)
    values = _window_ranks(padded, image.shape[:2], footprint, ranks)
    if image.ndim == 3:
        values = [jnp.moveaxis(v, 0, -1) for v in values]
    return _guard_image(_combine_middle(values, image.dtype), image, cval if guard_cval else None)


def _correlate_separable(padded, shape_hw, kernels):
    """Correlate the last two axes of `padded` with a row kernel and a column kernel."""
    height, width = shape_hw
    rows = sum(w * padded[..., i : i + height, :] for i, w in enumerate(kernels[0]))
    return sum(w * rows[..., j : j + width] for j, w in enumerate(kernels[1]))


def _on_planes(filter_planes, image):
    """Apply a filter of the last two axes to an `(H, W)` or `(H, W, C)` image."""
    if image.ndim == 2:
        return filter_planes(image)
    return jnp.moveaxis(filter_planes(jnp.moveaxis(image, -1, 0)), 0, -1)


def mean_filter(
    image: Float[Array, "H W *C"],
    *,
    size: int | tuple[int, int] = 3,
    mode: str = "reflect",
    cval: float = 0.0,
) -> Float[Array, "H W *C"]:
    """Mean (box) filter, the linear counterpart of `median_filter`.

    Matches `scipy.ndimage.uniform_filter` of a float image with the same `size`, `mode`
    and `cval` (same window placement as `median_filter`).

    **Arguments:**

    - `image`: `(H, W)` or `(H, W, C)`; integer images are converted to float.
    - `size`: window size, an int or `(rows, cols)`, each at most `2 MAX_KERNEL_RADIUS + 1`.
    - `mode`, `cval`: border handling as in `median_filter`.

    **Returns:**

    The filtered float image.
    """
    image = _check_filter_image(image)
    mode = _check_mode(mode)
    cval = _check_cval(cval, image)
    kh, kw = _window_size(size, 2 * MAX_KERNEL_RADIUS + 1)
    return _mean_filter(image, cval, size=(kh, kw), mode=mode, guard_cval=is_traced(cval))


@functools.partial(checked_jit, static_argnames=("size", "mode", "guard_cval"))
def _mean_filter(image, cval, *, size, mode, guard_cval):
    source = image
    image = image.astype(float_dtype(image))
    kh, kw = size
    kernels = ([1.0 / kh] * kh, [1.0 / kw] * kw)
    out = _on_planes(
        lambda x: _correlate_separable(_pad(x, (kh, kw), mode, cval), image.shape[:2], kernels),
        image,
    )
    return _guard_image(out, source, cval if guard_cval else None)


def gaussian_filter(
    image: Float[Array, "H W *C"],
    *,
    sigma: float | tuple[float, float],
    truncate: float = 4.0,
    radius: int | tuple[int, int] | None = None,
    mode: str = "reflect",
    cval: float = 0.0,
) -> Float[Array, "H W *C"]:
    """Gaussian blur, matching `scipy.ndimage.gaussian_filter` with the same arguments.

    The kernel along each axis has weights `exp(-x^2 / (2 sigma^2))`, `x = -r..r`,
    normalised to sum 1, with `r = int(truncate * sigma + 0.5)` unless `radius` is given.
    `sigma` may be traced (e.g. fitted) when `radius` is given, since the radius sets an
    array size and must be static.

    **Arguments:**

    - `image`: `(H, W)` or `(H, W, C)`; integer images are converted to float.
    - `sigma`: standard deviation in pixels (finite, > 0), one value or `(rows, cols)`.
    - `truncate`: radius in units of sigma when `radius` is not given (finite, >= 0).
    - `radius`: kernel radius, an int or `(rows, cols)` (static). Either way the radius
      is at most `MAX_KERNEL_RADIUS` (a documented limit).
    - `mode`, `cval`: border handling as in `median_filter`.

    **Returns:**

    The blurred float image.
    """
    image = _check_filter_image(image)
    mode = _check_mode(mode)
    cval = _check_cval(cval, image)
    sigma = _check_sigma(sigma)
    if radius is None:
        if is_traced(sigma):
            raise TypeError("a traced `sigma` needs a static `radius=` (the kernel size)")
        truncate = float(float_scalar(truncate, "truncate", low=0, low_open=False))
        radii = tuple(int(truncate * float(s) + 0.5) for s in np.broadcast_to(sigma, (2,)))
        if max(radii) > MAX_KERNEL_RADIUS:
            raise ValueError(
                f"`truncate * sigma` must be <= {MAX_KERNEL_RADIUS} (the largest kernel "
                f"radius, a documented size limit), got radii {radii} for sigma={sigma.tolist()}"
            )
    else:
        if isinstance(radius, Sequence) and not isinstance(radius, str):
            radii = tuple(radius)
        else:
            radii = (radius, radius)
        if len(radii) != 2:
            raise ValueError(f"`radius` must be an int or a pair (rows, cols), got {radius!r}")
        radii = tuple(static_int(r, "radius", minimum=0, maximum=MAX_KERNEL_RADIUS) for r in radii)
    return _gaussian_filter(image, sigma, cval, radii=radii, mode=mode, guard_cval=is_traced(cval))


def _check_sigma(sigma):
    """Finite, positive standard deviations: one or `(rows, cols)`; NumPy when concrete."""
    if isinstance(sigma, int | float) and not isinstance(sigma, bool):
        return np.float64(float_scalar(sigma, "sigma", low=0))
    arr = array_arg(sigma, "sigma", "a positive number or a pair (rows, cols)")
    if arr.shape not in ((), (1,), (2,)):
        raise ValueError(f"`sigma` must be a number or a pair (rows, cols), got shape {arr.shape}")
    if not is_traced(sigma):
        arr = np.asarray(sigma, dtype=float)
    return range_check(finite_arg(arr, "sigma"), "sigma", low=0)


@functools.partial(checked_jit, static_argnames=("radii", "mode", "guard_cval"))
def _gaussian_filter(image, sigma, cval, *, radii, mode, guard_cval):
    source = image
    image = image.astype(float_dtype(image))
    sigma = jnp.broadcast_to(jnp.asarray(sigma).astype(image.dtype), (2,))
    kernels = []
    for axis, r in enumerate(radii):
        x = jnp.arange(-r, r + 1, dtype=image.dtype)
        w = jnp.exp(-0.5 * (x / sigma[axis]) ** 2)
        kernels.append(list(w / jnp.sum(w)))
    window = (2 * radii[0] + 1, 2 * radii[1] + 1)
    out = _on_planes(
        lambda x: _correlate_separable(_pad(x, window, mode, cval), image.shape[:2], kernels),
        image,
    )
    return _guard_image(out, source, cval if guard_cval else None)
