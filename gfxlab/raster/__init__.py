"""Scan conversion on the pixel grid: lines, circles, ellipses, polygon fill,
anti-aliasing and a simulation of raster-scan and random-scan displays.

Pixel convention (owned by `gfxlab._pixels`, re-exported here): geometry is y up, and
the pixel in array column `col`, row `row` of an `(H, W)` image has its centre at the
integer point `(x, y) = (col, H - 1 - row)`; it covers `[x - 1/2, x + 1/2] x
[y - 1/2, y + 1/2]`. `pixel_to_index` and `index_to_pixel` convert, and
`image_extent` gives the matching `extent=` for `matplotlib.pyplot.imshow`.

The submodules, all re-exported here:

- `lines`: `points_to_image`, DDA and Bresenham lines;
- `conics`: midpoint circles and ellipses;
- `polygons`: the even-odd inside test and polygon fill;
- `antialias`: supersampling and exact area coverage;
- `display`: raster-scan and random-scan displays, phosphor persistence.

Every stepwise textbook algorithm comes twice: a vectorized version for use (closed
forms over all steps at once) and a faithful step-by-step version (`*_steps`,
`*_trace`, built on `lax.scan`) that follows the textbook's decision parameters. The
tests check that the two agree exactly.

Sizes are static: line endpoints, radii and image shapes are Python ints, because
they fix how many pixels come out, and they are bounded by documented limits
(`MAX_LINE_COORDINATE`, `MAX_CIRCLE_RADIUS`, `MAX_ELLIPSE_RADIUS`, `MAX_IMAGE_SIDE`,
`MAX_SUPERSAMPLE`, `MAX_BEAM_STEPS`). Continuous inputs (polygon vertices, the
endpoints of the coverage functions, a circle's centre) may be traced; the coverage
functions are differentiable. Called eagerly, each function is one compiled call (or
none: pixels that depend on static ints only are computed in NumPy).
"""

from __future__ import annotations

from .._pixels import MAX_IMAGE_SIDE, image_extent, index_to_pixel, pixel_centers, pixel_to_index
from . import antialias, conics, display, lines, polygons
from .antialias import *  # noqa: F403
from .conics import *  # noqa: F403
from .display import *  # noqa: F403
from .lines import *  # noqa: F403
from .polygons import *  # noqa: F403

__all__ = [
    "pixel_to_index",
    "index_to_pixel",
    "image_extent",
    "pixel_centers",
    "MAX_IMAGE_SIDE",
    *lines.__all__,
    *conics.__all__,
    *polygons.__all__,
    *antialias.__all__,
    *display.__all__,
]
