"""Images: files and formats, raster versus vector, median and linear filters, noise.

An image here is a raster: an array `(H, W)` (grey) or `(H, W, C)` (colour, C channels)
of samples on the pixel grid. Inside differentiable code the samples are floats in
[0, 1]; at the file boundary they are `uint8` (`read_image(..., as_float=False)`,
`write_image`: floats are clipped to [0, 1], scaled by 255 and rounded half to even,
booleans become 0/255). Pixel `(row, col)` has its centre at `(x, y) = (col, H - 1 - row)`
(y up), as everywhere in gfxlab (`gfxlab.raster.pixel_to_index`).

The submodules, all re-exported here:

- `io`: `read_image`, `write_image` and `image_info` for PNG, JPEG, BMP, TIFF and GIF
  through Pillow, imported only when a file is touched; `ImageFileError` for files
  Pillow cannot read.
- `shapes`: `Polygon`, `Polyline` and `Circle` describe vector shapes in pixel
  coordinates; `write_svg` writes them as an SVG file and `rasterize_shapes` turns the
  same shapes into pixels (supersampled coverage, with `gfxlab.raster`'s even-odd test
  and supersampling), so the two can be compared.
- `networks`: selection networks and `median` (a network, not a sort).
- `filters`: `median_filter`, a non-linear rank filter computed with a pruned
  sorting/selection network (compare-exchange = `minimum`/`maximum` of shifted views);
  `mean_filter` and `gaussian_filter` are the linear filters to contrast it with. All
  three match `scipy.ndimage` for every border mode.
- `noise`: `value_noise` (gfxlab's one value noise), `gradient_noise`, `fractal_noise`;
  randomness is a `jax.random` key (`key=`, default `DEFAULT_KEY` = `jax.random.key(0)`).
- `scenes`: `add_salt_and_pepper` and `synthetic_scene` (both take `key=`), test pictures.

Called eagerly, each function is one compiled call (checks in Python first; NaN/inf
in the data are checked inside that call, through `equinox.error_if`).

Examples:
    >>> import os, tempfile
    >>> import numpy as np
    >>> from gfxlab.image import read_image, write_image
    >>> ramp = np.linspace(0, 1, 16 * 16 * 3).reshape(16, 16, 3)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = write_image(os.path.join(folder, "ramp.png"), ramp)
    ...     image = read_image(path)  # floats in [0, 1], rounded to 8 bits in the file
    >>> image.shape, bool(np.abs(image - ramp).max() <= 0.5 / 255)
    ((16, 16, 3), True)
"""

from __future__ import annotations

from . import filters, io, networks, noise, scenes, shapes
from .filters import *  # noqa: F403
from .io import *  # noqa: F403
from .networks import *  # noqa: F403
from .noise import *  # noqa: F403
from .scenes import *  # noqa: F403
from .shapes import *  # noqa: F403

__all__ = [
    *io.__all__,
    *shapes.__all__,
    *networks.__all__,
    *filters.__all__,
    *noise.__all__,
    *scenes.__all__,
]
