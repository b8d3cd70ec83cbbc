"""The pixel grid: one owner for the raster conventions every module shares.

Geometry is y up. The pixel in array column `col`, row `row` of an `(H, W)` image has
its centre at the integer point `(x, y) = (col, H - 1 - row)` and covers
`[x - 1/2, x + 1/2] x [y - 1/2, y + 1/2]`. `pixel_to_index` and `index_to_pixel`
convert; `pixel_centers` lays the centres out like the image; `image_extent` gives the
matching `extent=` for `matplotlib.pyplot.imshow`; `subpixel_offsets` places the
samples of supersampling inside a pixel.

At file boundaries images are `uint8`; inside differentiable code they are floats in
[0, 1]. `to_uint8` and `to_float` are the only conversions between the two.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._checks import as_numeric, check_last_dim, static_int, static_shape

__all__ = [
    "pixel_to_index",
    "row_to_y",
    "index_to_pixel",
    "image_extent",
    "pixel_centers",
    "subpixel_offsets",
    "to_uint8",
    "to_float",
    "to_levels",
    "from_levels",
    "MAX_IMAGE_SIDE",
    "checked_shape",
]

#: Largest height or width of an image that a function allocates from a static `shape`
#: argument (a documented size limit: a larger value is refused before allocating).
MAX_IMAGE_SIDE = 16384


def row_to_y(row, height: int):
    """The y (up) of the pixel centres in array row `row` of an image `height` rows high.

    The flip is its own inverse: `row_to_y(y, height)` is the row of height `y`. Works
    on Python ints, NumPy and JAX arrays alike (inside a trace too).
    """
    return height - 1 - row


def pixel_to_index(xy: Int[Array, "*batch 2"], shape: tuple[int, int]) -> Int[Array, "*batch 2"]:
    """Pixel positions `(x, y)` (y up) to array indices `(row, col)` of an image of `shape`.

    **Arguments:**

    - `xy`: pixel positions, shape `(..., 2)`.
    - `shape`: the image shape `(H, W)`.

    **Returns:** `(row, col)` indices, shape `(..., 2)`. The map is affine and exact for
    any numbers: a fractional position gives a fractional index, and a position off the
    image an index outside `[0, H) x [0, W)` (bounds are the caller's to check).
    """
    height, _ = static_shape(shape)
    xy = as_numeric(xy, "xy")
    check_last_dim(xy, "xy", (2,), "pixel positions (x, y)")
    return jnp.stack([height - 1 - xy[..., 1], xy[..., 0]], axis=-1)


def index_to_pixel(rc: Int[Array, "*batch 2"], shape: tuple[int, int]) -> Int[Array, "*batch 2"]:
    """Array indices `(row, col)` to pixel positions `(x, y)` (y up) of an image of `shape`.

    **Arguments:**

    - `rc`: array indices, shape `(..., 2)`.
    - `shape`: the image shape `(H, W)`.

    **Returns:** `(x, y)` pixel positions, shape `(..., 2)`.
    """
    height, _ = static_shape(shape)
    rc = as_numeric(rc, "rc")
    check_last_dim(rc, "rc", (2,), "array indices (row, col)")
    return jnp.stack([rc[..., 1], height - 1 - rc[..., 0]], axis=-1)


def checked_shape(shape, name: str = "shape") -> tuple[int, int]:
    """A static image shape `(H, W)` with both sides in `1..MAX_IMAGE_SIDE`.

    Extra trailing entries (channels) are ignored. Raises `TypeError`/`ValueError`
    naming `name` otherwise.
    """
    if shape is None:
        raise TypeError(f"`{name}` must be an image shape (H, W), got None")
    height, width = static_shape(shape, name)
    for value, side in ((height, f"{name}[0]"), (width, f"{name}[1]")):
        static_int(value, side, maximum=MAX_IMAGE_SIDE)
    return height, width


def image_extent(shape: tuple[int, int]) -> tuple[float, float, float, float]:
    """`extent=` for `plt.imshow(image, extent=...)` so that axes read pixel (x, y), y up.

    With it, a point drawn at `(x, y)` lands on the centre of the pixel
    `pixel_to_index((x, y), shape)`.
    """
    height, width = static_shape(shape)
    return (-0.5, width - 0.5, -0.5, height - 0.5)


def pixel_centers(shape: tuple[int, int], *, dtype=None) -> Float[Array, "H W 2"]:
    """The centre `(x, y)` of every pixel of an `(H, W)` image, laid out like the image.

    `pixel_centers(shape)[row, col] == (col, H - 1 - row)`.
    """
    height, width = static_shape(shape)
    dtype = jnp.result_type(float) if dtype is None else dtype
    rows, cols = jnp.meshgrid(jnp.arange(height), jnp.arange(width), indexing="ij")
    return jnp.stack([cols, height - 1 - rows], axis=-1).astype(dtype)


def subpixel_offsets(samples_per_axis: int, *, dtype=None) -> Float[Array, "S 2"]:
    """Offsets `(dx, dy)` of an `n x n` regular grid of samples inside one pixel.

    The samples sit at the centres of the `n x n` sub-cells of the pixel square
    `[-1/2, 1/2]^2`, so their mean is the pixel centre.

    **Arguments:**

    - `samples_per_axis`: `n`, a static int >= 1.

    **Returns:** the `n * n` offsets, row-major from the bottom-left sub-cell.
    """
    n = static_int(samples_per_axis, "samples_per_axis", minimum=1)
    dtype = jnp.result_type(float) if dtype is None else dtype
    centres = (np.arange(n) + 0.5) / n - 0.5
    dx, dy = np.meshgrid(centres, centres)
    return jnp.asarray(np.stack([dx.ravel(), dy.ravel()], axis=-1), dtype=dtype)


def to_uint8(image, name: str = "image") -> np.ndarray:
    """An image as a NumPy `uint8` array, for writing to a file.

    Floats are taken as [0, 1], clipped, scaled by 255 and rounded half to even (as
    `np.round`); booleans become 0/255; integers must already lie in 0..255.

    **Arguments:**

    - `image`: any array of samples.
    - `name`: the argument name used in error messages.

    **Returns:** a `uint8` NumPy array of the same shape.
    """
    if image is None:
        raise TypeError(f"`{name}` must be an image array, got None")
    arr = np.asarray(jax.device_get(image)) if isinstance(image, jax.Array) else np.asarray(image)
    if arr.dtype == np.uint8:
        return arr
    if arr.dtype == np.bool_:
        return arr.astype(np.uint8) * np.uint8(255)
    if np.issubdtype(arr.dtype, np.floating):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"`{name}` has NaN or infinite samples")
        return np.round(np.clip(arr, 0.0, 1.0) * 255.0).astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer):
        if arr.size and (arr.min() < 0 or arr.max() > 255):
            raise ValueError(
                f"integer `{name}` must have samples in 0..255, got {arr.min()}..{arr.max()}"
            )
        return arr.astype(np.uint8)
    raise TypeError(f"`{name}` must be a float image in [0, 1] or uint8, got dtype {arr.dtype}")


def to_levels(image: jax.Array) -> jax.Array:
    """Inside a trace: floats in [0, 1] to the int32 levels 0..255 `to_uint8` writes.

    Clipped, scaled by 255 and rounded half to even, like `to_uint8`, but traceable
    (no checks: for code that models a file format, e.g. the JPEG encoder).
    """
    return jnp.round(jnp.clip(image, 0.0, 1.0) * 255.0).astype(jnp.int32)


def from_levels(levels: jax.Array, dtype) -> jax.Array:
    """Inside a trace: levels 0..255 (any number type) back to floats in [0, 1] of `dtype`."""
    return levels.astype(dtype) / 255.0


def to_float(image, name: str = "image", *, dtype=None) -> jax.Array:
    """An image as floats in [0, 1]: `uint8` is divided by 255, floats are kept.

    **Arguments:**

    - `image`: a `uint8`, boolean or float array.
    - `name`: the argument name used in error messages.
    - `dtype`: the float dtype of the result (default: the input's float dtype, or
      JAX's default float for integer input).

    **Returns:** a float JAX array of the same shape.
    """
    if image is None:
        raise TypeError(f"`{name}` must be an image array, got None")
    arr = jnp.asarray(image)
    if arr.dtype == jnp.uint8:  # a look-up: exactly `level / 255` (a division may round off)
        out = jnp.asarray(_unit_levels(jnp.dtype(dtype or jnp.result_type(float))))[arr]
    elif arr.dtype == jnp.bool_:
        out = arr.astype(dtype or jnp.result_type(float))
    elif jnp.issubdtype(arr.dtype, jnp.floating):
        out = arr
    else:
        raise TypeError(f"`{name}` must be a float image in [0, 1] or uint8, got dtype {arr.dtype}")
    return out if dtype is None else out.astype(dtype)


@functools.cache
def _unit_levels(dtype) -> np.ndarray:
    """`level / 255` for the 256 levels of a `uint8` sample, correctly rounded to `dtype`."""
    return (np.arange(256) / 255.0).astype(dtype)
