"""Raster versus vector: `Polygon`, `Polyline` and `Circle` in pixel coordinates,
written as SVG (`write_svg`) or rasterized (`rasterize_shapes`).

The rasterizer uses `gfxlab.raster`'s even-odd inside test and supersampling (their
one owner), so a filled polygon here covers exactly the samples `raster.fill_polygon`
and `raster.supersample` would.
"""

from __future__ import annotations

import functools
import os
import pathlib
from collections.abc import Iterable, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import check_shape, is_traced, static_int, value_error_if
from .._pixels import checked_shape
from ..raster._args import array_arg, finite_arg
from ..raster.antialias import MAX_SUPERSAMPLE, supersample_values
from ..raster.polygons import even_odd
from .io import _check_path

__all__ = ["Polygon", "Polyline", "Circle", "write_svg", "rasterize_shapes"]


def _colour(value, name: str) -> tuple[float, float, float] | None:
    """An RGB colour in [0, 1] as a tuple of floats (a grey level is broadcast), or None."""
    if value is None:
        return None
    try:
        rgb = tuple(float(v) for v in np.broadcast_to(np.asarray(value, dtype=float), (3,)))
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"`{name}` must be an RGB colour (3 numbers in [0, 1]) or None, got {value!r}"
        ) from err
    if not all(0.0 <= v <= 1.0 for v in rgb):
        raise ValueError(f"`{name}` must be an RGB colour with entries in [0, 1], got {value!r}")
    return rgb


def _required_colour(value, name: str) -> tuple[float, float, float]:
    """An RGB colour in [0, 1] as a tuple of floats; `None` is a `TypeError`."""
    if value is None:
        raise TypeError(f"`{name}` must be an RGB colour (3 numbers in [0, 1]), got None")
    return _colour(value, name)


def _stroke_width(value) -> float:
    if value is None or isinstance(value, bool | str | bytes):
        raise TypeError(f"`stroke_width` must be a number of pixels, got {value!r}")
    try:
        width = float(value)
    except (TypeError, ValueError) as err:
        raise TypeError(f"`stroke_width` must be a number of pixels, got {value!r}") from err
    if not np.isfinite(width) or width < 0:
        raise ValueError(f"`stroke_width` must be finite and >= 0, got {value!r}")
    return width


def _points(value, name: str, what: str):
    """Finite `(N, 2)` points, kept as given (a traced array stays traced)."""
    arr = array_arg(value, name)
    check_shape(arr, name, (None, 2))
    return jnp.asarray(finite_arg(arr, name))


def _scalar(value, name: str, *, minimum: float = 0.0):
    arr = array_arg(value, name, "a real number")
    check_shape(arr, name, ())
    if not is_traced(value) and not (np.isfinite(float(arr)) and float(arr) >= minimum):
        raise ValueError(f"`{name}` must be finite and >= {minimum:g}, got {value!r}")
    if is_traced(value):
        arr = value_error_if(
            arr,
            ~(jnp.isfinite(arr) & (arr >= minimum)),
            f"`{name}` must be finite and >= {minimum:g}",
        )
    return jnp.asarray(arr)


class Polygon(eqx.Module):
    """A closed polygon in pixel coordinates (y up), filled with the even-odd rule.

    **Fields:** `vertices` `(V, 2)`; `fill`, `stroke` RGB colours in [0, 1] or
    `None`; `stroke_width` in pixels (round joins). Checked at construction.
    """

    vertices: Float[Array, "V 2"] = eqx.field(
        converter=functools.partial(_points, name="vertices", what="polygon vertices (x, y)")
    )
    fill: tuple | None = eqx.field(
        static=True, default=(0.0, 0.0, 0.0), converter=functools.partial(_colour, name="fill")
    )
    stroke: tuple | None = eqx.field(
        static=True, default=None, converter=functools.partial(_colour, name="stroke")
    )
    stroke_width: float = eqx.field(static=True, default=1.0, converter=_stroke_width)


class Polyline(eqx.Module):
    """An open polyline in pixel coordinates (y up), stroked with round caps and joins.

    **Fields:** `vertices` `(V, 2)`; `stroke` RGB colour in [0, 1]; `stroke_width` in pixels.
    Checked at construction.
    """

    vertices: Float[Array, "V 2"] = eqx.field(
        converter=functools.partial(_points, name="vertices", what="polyline vertices (x, y)")
    )
    stroke: tuple = eqx.field(
        static=True,
        default=(0.0, 0.0, 0.0),
        converter=functools.partial(_required_colour, name="stroke"),
    )
    stroke_width: float = eqx.field(static=True, default=1.0, converter=_stroke_width)


class Circle(eqx.Module):
    """A circle in pixel coordinates (y up).

    **Fields:** `center` `(2,)`; `radius` (>= 0); `fill`, `stroke` RGB colours in [0, 1]
    or `None`; `stroke_width` in pixels. Checked at construction: `Circle(c, "abc")`
    raises `TypeError`, a negative or NaN radius `ValueError`.
    """

    center: Float[Array, "2"] = eqx.field(converter=lambda c: _center(c))
    radius: Float[Array, ""] = eqx.field(converter=lambda r: _scalar(r, "radius"))
    fill: tuple | None = eqx.field(
        static=True, default=(0.0, 0.0, 0.0), converter=functools.partial(_colour, name="fill")
    )
    stroke: tuple | None = eqx.field(
        static=True, default=None, converter=functools.partial(_colour, name="stroke")
    )
    stroke_width: float = eqx.field(static=True, default=1.0, converter=_stroke_width)


def _center(value):
    arr = array_arg(value, "center")
    check_shape(arr, "center", (2,))
    return jnp.asarray(finite_arg(arr, "center"))


def _check_shapes(shapes) -> list:
    if isinstance(shapes, Polygon | Polyline | Circle):
        shapes = [shapes]
    if shapes is None or isinstance(shapes, str | bytes) or not isinstance(shapes, Iterable):
        raise TypeError(f"`shapes` must be a list of Polygon, Polyline or Circle, got {shapes!r}")
    shapes = list(shapes)
    for s in shapes:
        if not isinstance(s, Polygon | Polyline | Circle):
            raise TypeError(
                f"`shapes` must hold Polygon, Polyline or Circle, got {type(s).__name__}"
            )
    return shapes


def _svg_colour(rgb) -> str:
    if rgb is None:
        return "none"
    r, g, b = (round(255 * c) for c in _colour(rgb, "colour"))
    return f"#{r:02x}{g:02x}{b:02x}"


def write_svg(
    path: str | os.PathLike,
    shapes: Sequence[Polygon | Polyline | Circle],
    shape: tuple[int, int],
    *,
    background: tuple | None = (1.0, 1.0, 1.0),
) -> pathlib.Path:
    """Write vector shapes as an SVG file covering an `(H, W)` pixel grid.

    Shapes are in gfxlab pixel coordinates (y up, pixel centres at integers); SVG has y
    down with pixel `(row, col)` covering `[col, col + 1] x [row, row + 1]`, so a point
    `(x, y)` is written as `(x + 1/2, H - 1/2 - y)`. `rasterize_shapes(shapes, shape)`
    draws the same picture as pixels.

    **Arguments:**

    - `path`: the `.svg` file to write (the name must end in `.svg`).
    - `shapes`: `Polygon`, `Polyline` and `Circle` objects, drawn in order (painter's).
    - `shape`: `(H, W)`, the size of the canvas in pixels.
    - `background`: RGB colour in [0, 1] of the canvas, or `None` for transparent.

    **Returns:**

    The path written.
    """
    path = _check_path(path)
    if path.suffix.lower() != ".svg":
        raise ValueError(f"`path` must name an .svg file, got {str(path)!r}")
    height, width = checked_shape(shape)
    shapes = _check_shapes(shapes)
    background = _colour(background, "background")

    def xy(p):
        p = np.asarray(p, dtype=float).reshape(-1, 2)
        return " ".join(f"{x + 0.5:.6g},{height - 0.5 - y:.6g}" for x, y in p)

    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}">',
    ]
    if background is not None:
        lines.append(
            f'  <rect x="0" y="0" width="{width}" height="{height}" '
            f'fill="{_svg_colour(background)}"/>'
        )
    for s in shapes:
        if isinstance(s, Polygon):
            lines.append(
                f'  <polygon points="{xy(s.vertices)}" fill="{_svg_colour(s.fill)}" '
                f'fill-rule="evenodd" stroke="{_svg_colour(s.stroke)}" '
                f'stroke-width="{s.stroke_width:g}" stroke-linejoin="round"/>'
            )
        elif isinstance(s, Polyline):
            lines.append(
                f'  <polyline points="{xy(s.vertices)}" fill="none" '
                f'stroke="{_svg_colour(s.stroke)}" stroke-width="{s.stroke_width:g}" '
                'stroke-linecap="round" stroke-linejoin="round"/>'
            )
        else:
            (cx, cy), r = np.asarray(s.center, float), float(s.radius)
            lines.append(
                f'  <circle cx="{cx + 0.5:.6g}" cy="{height - 0.5 - cy:.6g}" '
                f'r="{r:.6g}" fill="{_svg_colour(s.fill)}" '
                f'stroke="{_svg_colour(s.stroke)}" stroke-width="{s.stroke_width:g}"/>'
            )
    lines.append("  <!-- written by gfxlab.image.write_svg -->")
    lines.append("</svg>")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _segment_distance(px, py, a, b):
    """Distance from sample points to the segments `a[i] -> b[i]` (min over segments)."""
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    px, py = px[..., None], py[..., None]
    t = ((px - ax) * dx + (py - ay) * dy) / jnp.where(length2 > 0, length2, 1.0)
    t = jnp.clip(t, 0.0, 1.0)
    return jnp.min(jnp.hypot(px - ax - t * dx, py - ay - t * dy), axis=-1)


def rasterize_shapes(
    shapes: Sequence[Polygon | Polyline | Circle],
    shape: tuple[int, int],
    *,
    samples: int = 4,
    background: tuple = (1.0, 1.0, 1.0),
) -> Float[Array, "H W 3"]:
    """Rasterize vector shapes onto an `(H, W)` pixel grid (the raster side of `write_svg`).

    Every pixel is sampled on a `samples x samples` grid of points; each sample
    takes the colour of the last shape covering it (fill by the even-odd rule, strokes
    with round caps and joins), and the pixel is the mean of its samples (box-filter
    anti-aliasing). The coverage is a step function of the shape parameters, so this is
    not differentiable with respect to them (soft rasterization belongs to `gfxlab.render`).

    **Arguments:**

    - `shapes`: `Polygon`, `Polyline` and `Circle` objects in pixel coordinates (y up).
    - `shape`: `(H, W)`.
    - `samples`: samples per pixel along each axis (static, `1..MAX_SUPERSAMPLE`).
    - `background`: RGB colour in [0, 1].

    **Returns:**

    An `(H, W, 3)` float image in [0, 1].
    """
    height, width = checked_shape(shape)
    s = static_int(samples, "samples", minimum=1, maximum=MAX_SUPERSAMPLE)
    shapes = _check_shapes(shapes)
    background = _required_colour(background, "background")
    return _rasterize(shapes, (height, width), s, background)


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _rasterize(shapes, shape, s, background):
    dtype = jnp.result_type(float)

    def paint_samples(samples):
        px, py = samples[..., 0], samples[..., 1]
        canvas = jnp.broadcast_to(jnp.asarray(background, dtype), (*px.shape, 3))
        for sh in shapes:
            canvas = _paint_shape(canvas, sh, samples, px, py, dtype)
        return canvas

    return supersample_values(paint_samples, shape, s, dtype=dtype, trailing=1)


def _paint_shape(canvas, sh, samples, px, py, dtype):
    """Paint one shape's fill, then its stroke, over the samples' colours."""

    def paint(canvas, mask, rgb):
        if rgb is None:
            return canvas
        return jnp.where(mask[..., None], jnp.asarray(rgb, dtype), canvas)

    if isinstance(sh, Circle):
        center = sh.center.astype(dtype)
        radius = sh.radius.astype(dtype)
        d = jnp.hypot(px - center[0], py - center[1])
        canvas = paint(canvas, d <= radius, sh.fill)
        return paint(canvas, jnp.abs(d - radius) <= sh.stroke_width / 2, sh.stroke)
    pts = sh.vertices.astype(dtype)
    if isinstance(sh, Polygon):
        canvas = paint(canvas, even_odd(samples, pts), sh.fill)
        a, b = pts, jnp.roll(pts, -1, axis=0)
    else:
        a, b = pts[:-1], pts[1:]
    if sh.stroke is not None and a.shape[0] > 0:
        canvas = paint(canvas, _segment_distance(px, py, a, b) <= sh.stroke_width / 2, sh.stroke)
    return canvas
