"""Scan conversion on the pixel grid.

Pixel convention (used by every module and every plot): geometry is y up, and the
pixel in array column `col`, row `row` of an `(H, W)` image has its centre at the
integer point `(x, y) = (col, H - 1 - row)`; it covers `[x - 1/2, x + 1/2] x
[y - 1/2, y + 1/2]`. `pixel_to_index` and `index_to_pixel` convert, and
`image_extent` gives the matching `extent=` for `matplotlib.pyplot.imshow`.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, Int

from ._checks import check_last_dim, static_shape

__all__ = ["pixel_to_index", "index_to_pixel", "image_extent"]


def pixel_to_index(xy: Int[Array, "*batch 2"], shape: tuple[int, int]) -> Int[Array, "*batch 2"]:
    """Pixel positions `(x, y)` (y up) to array indices `(row, col)` of an image of `shape`."""
    height, _ = static_shape(shape)
    xy = jnp.asarray(xy)
    check_last_dim(xy, "xy", (2,), "pixel positions (x, y)")
    return jnp.stack([height - 1 - xy[..., 1], xy[..., 0]], axis=-1)


def index_to_pixel(rc: Int[Array, "*batch 2"], shape: tuple[int, int]) -> Int[Array, "*batch 2"]:
    """Array indices `(row, col)` to pixel positions `(x, y)` (y up) of an image of `shape`."""
    height, _ = static_shape(shape)
    rc = jnp.asarray(rc)
    check_last_dim(rc, "rc", (2,), "array indices (row, col)")
    return jnp.stack([rc[..., 1], height - 1 - rc[..., 0]], axis=-1)


def image_extent(shape: tuple[int, int]) -> tuple[float, float, float, float]:
    """`extent=` for `plt.imshow(image, extent=...)` so that axes read pixel (x, y), y up.

    With it, a point drawn at `(x, y)` lands on the centre of the pixel
    `pixel_to_index((x, y), shape)`.
    """
    height, width = static_shape(shape)
    return (-0.5, width - 0.5, -0.5, height - 0.5)


del jax
