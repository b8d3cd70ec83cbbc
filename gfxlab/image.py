"""Images: files and formats, raster versus vector, median and linear filters.

An image here is a raster: an array `(H, W)` (grey) or `(H, W, C)` (colour, C channels)
of samples on the pixel grid. Inside differentiable code the samples are floats in
[0, 1]; at the file boundary they are `uint8` (`read_image(..., as_float=False)`,
`write_image`). Pixel `(row, col)` has its centre at `(x, y) = (col, H - 1 - row)`
(y up), as everywhere in gfxlab (`gfxlab.raster.pixel_to_index`).

- **Files.** `read_image`, `write_image` and `image_info` for PNG, JPEG, BMP, TIFF and GIF
  go through Pillow, imported only when a file is touched.
- **Raster versus vector.** `Polygon`, `Polyline` and `Circle` describe vector shapes in
  pixel coordinates; `write_svg` writes them as an SVG file and `rasterize_shapes` turns the
  same shapes into pixels (supersampled coverage), so the two can be compared.
- **Filters.** `median_filter` is a non-linear rank filter computed with a pruned
  sorting/selection network (compare-exchange = `minimum`/`maximum` of shifted views);
  `mean_filter` and `gaussian_filter` are the linear filters to contrast it with. All
  three match `scipy.ndimage` for every border mode.
"""

from __future__ import annotations

import functools
import math
import os
import pathlib
from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Shaped

from ._checks import as_float, check_last_dim, static_int, static_shape, value_error_if

__all__ = [
    "FORMATS",
    "MODES",
    "read_image",
    "write_image",
    "image_info",
    "Polygon",
    "Polyline",
    "Circle",
    "write_svg",
    "rasterize_shapes",
    "median",
    "median_filter",
    "mean_filter",
    "gaussian_filter",
    "median_of_sum",
    "cross_footprint",
    "selection_network",
    "add_salt_and_pepper",
    "synthetic_scene",
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

#: File formats written and read by `write_image`/`read_image` (Pillow names), with the
#: file extensions that select them.
FORMATS = {
    "PNG": (".png",),
    "JPEG": (".jpg", ".jpeg", ".jpe", ".jfif"),
    "BMP": (".bmp", ".dib"),
    "TIFF": (".tif", ".tiff"),
    "GIF": (".gif",),
}


# --------------------------------------------------------------------------------------
# Files
# --------------------------------------------------------------------------------------


def _format_for(path: pathlib.Path, format: str | None) -> str:
    if format is not None:
        if not isinstance(format, str) or format.upper().replace("JPG", "JPEG") not in FORMATS:
            raise ValueError(f"`format` must be one of {sorted(FORMATS)}, got {format!r}")
        return format.upper().replace("JPG", "JPEG")
    suffix = path.suffix.lower()
    for name, suffixes in FORMATS.items():
        if suffix in suffixes:
            return name
    raise ValueError(
        f"cannot tell the image format from the file name {path.name!r}: use an extension in "
        f"{[s for v in FORMATS.values() for s in v]} or pass `format=` (one of {sorted(FORMATS)})"
    )


def _to_uint8(image, name: str = "image") -> np.ndarray:
    """An image as uint8: floats in [0, 1] are scaled by 255 and rounded."""
    arr = np.asarray(image)
    if arr.dtype == np.uint8:
        return arr
    if arr.dtype == np.bool_:
        return arr.astype(np.uint8) * 255
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


def _check_image_shape(arr: np.ndarray, name: str = "image") -> None:
    if arr.ndim == 2 or (arr.ndim == 3 and arr.shape[-1] in (1, 2, 3, 4)):
        if arr.shape[0] >= 1 and arr.shape[1] >= 1:
            return
    raise ValueError(
        f"`{name}` must have shape (H, W) or (H, W, C) with C in 1..4, got shape {arr.shape}"
    )


def _gif_frame_with_transparency(arr: np.ndarray):
    """A palette image for GIF: at most 255 colours plus entry 255, fully transparent
    where alpha < 128 (GIF has one transparent palette entry, no partial alpha)."""
    from PIL import Image

    colour, alpha = arr[..., :-1], arr[..., -1]
    rgb = Image.fromarray(colour).convert("RGB")
    quantized = rgb.quantize(colors=255)
    index = np.array(quantized, dtype=np.uint8)
    index[alpha < 128] = 255
    palette = (quantized.getpalette() or [])[: 3 * 255]
    palette = palette + [0] * (3 * 256 - len(palette))
    out = Image.fromarray(index, mode="P")
    out.putpalette(palette)
    out.info["transparency"] = 255
    return out


def write_image(
    path: str | os.PathLike,
    image: Shaped[Array, "H W *C"] | Sequence[Shaped[Array, "H W *C"]],
    *,
    format: str | None = None,
    **options,
) -> pathlib.Path:
    """Write an image file (PNG, JPEG, BMP, TIFF or GIF) with Pillow.

    **Arguments:**

    - `path`: the file to write; its extension picks the format unless `format` is given.
    - `image`: `(H, W)` grey or `(H, W, C)` with C = 1 (grey), 2 (grey + alpha), 3 (RGB) or
      4 (RGBA); floats in [0, 1] (clipped, scaled by 255 and rounded) or uint8. A list of
      such images of one shape writes an animation (GIF, PNG as APNG, multi-page TIFF).
    - `format`: `"PNG"`, `"JPEG"` (or `"JPG"`), `"BMP"`, `"TIFF"` or `"GIF"`.
    - `options`: passed to `PIL.Image.Image.save`, e.g. `quality=90, subsampling=0` for
      JPEG, `compress_level=9` for PNG, `compression="tiff_lzw"` for TIFF, `duration=100,
      loop=0` for an animated GIF.

    **Returns:**

    The path written, as a `pathlib.Path`.

    JPEG and BMP (as Pillow writes it) store no alpha channel, so an image with alpha
    raises `ValueError` for them. GIF stores at most 256 colours per frame: richer images
    are quantized (lossy), and alpha becomes one transparent palette entry (alpha < 1/2).
    """
    from PIL import Image

    path = pathlib.Path(path)
    fmt = _format_for(path, format)
    frames = list(image) if isinstance(image, list | tuple) else [image]
    if not frames:
        raise ValueError("`image` is an empty list of frames")
    arrays = [_to_uint8(f, "image") for f in frames]
    for arr in arrays:
        _check_image_shape(arr)
    if any(a.shape != arrays[0].shape for a in arrays):
        raise ValueError(f"all frames must have one shape, got {[a.shape for a in arrays]}")
    arrays = [a[..., 0] if a.ndim == 3 and a.shape[-1] == 1 else a for a in arrays]
    channels = 1 if arrays[0].ndim == 2 else arrays[0].shape[-1]
    if fmt in ("JPEG", "BMP") and channels in (2, 4):
        raise ValueError(f"{fmt} cannot store an alpha channel: pass a grey or RGB `image`")
    if fmt == "GIF" and channels in (2, 4):
        pil = [_gif_frame_with_transparency(a) for a in arrays]
        options = {"transparency": 255, "disposal": 2, **options}
    else:
        pil = [Image.fromarray(a) for a in arrays]
    if len(pil) > 1:
        if fmt not in ("GIF", "PNG", "TIFF"):
            raise ValueError(f"{fmt} cannot store an animation; use GIF, PNG or TIFF")
        options = {"save_all": True, "append_images": pil[1:], **options}
    pil[0].save(path, format=fmt, **options)
    return path


def read_image(
    path: str | os.PathLike, *, as_float: bool = True, frame: int = 0
) -> Float[Array, "H W *C"] | np.ndarray:
    """Read an image file with Pillow.

    **Arguments:**

    - `path`: a PNG, JPEG, BMP, TIFF or GIF file (anything Pillow opens).
    - `as_float`: return floats in [0, 1] (a JAX array, the default float dtype) instead of
      the file's integer samples (a NumPy `uint8` array, `uint16` for 16-bit files).
    - `frame`: which frame of an animated file (GIF, APNG, multi-page TIFF).

    **Returns:**

    `(H, W)` for grey images, `(H, W, 2)` grey + alpha, `(H, W, 3)` RGB, `(H, W, 4)` RGBA.
    Palette images are expanded to RGB (RGBA when the palette has transparency), bilevel
    images to grey 0/255, CMYK and YCbCr to RGB.
    """
    from PIL import Image

    frame = static_int(frame, "frame", minimum=0)
    with Image.open(path) as im:
        frames = getattr(im, "n_frames", 1)
        if frame >= frames:
            raise ValueError(f"`frame` must be < {frames} (the file has {frames}), got {frame}")
        im.seek(frame)
        mode = im.mode
        if mode == "P" or mode == "PA":
            im = im.convert("RGBA" if ("transparency" in im.info or mode == "PA") else "RGB")
        elif mode == "1":
            im = im.convert("L")
        elif mode in ("CMYK", "YCbCr", "LAB", "HSV"):
            im = im.convert("RGB")
        elif mode == "La":
            im = im.convert("LA")
        elif mode == "RGBa":
            im = im.convert("RGBA")
        arr = np.asarray(im)
    if arr.dtype == np.uint8:
        scale = 255.0
    elif arr.dtype in (np.uint16, np.dtype(">u2"), np.int32) and mode.startswith("I"):
        arr, scale = arr.astype(np.uint16), 65535.0
    elif np.issubdtype(arr.dtype, np.floating):
        return jnp.asarray(arr, dtype=jnp.result_type(float)) if as_float else arr
    else:
        raise ValueError(f"unsupported image mode {mode!r} in {os.fspath(path)!r}")
    if not as_float:
        return arr
    return jnp.asarray(arr / scale, dtype=jnp.result_type(float))


_MODE_BITS = {
    "1": 1,
    "L": 8,
    "P": 8,
    "LA": 8,
    "PA": 8,
    "RGB": 8,
    "RGBA": 8,
    "RGBX": 8,
    "CMYK": 8,
    "YCbCr": 8,
    "LAB": 8,
    "HSV": 8,
    "I": 32,
    "F": 32,
    "I;16": 16,
    "I;16B": 16,
    "I;16L": 16,
    "I;16N": 16,
}
_LOSSLESS = {"PNG": True, "JPEG": False, "BMP": True, "TIFF": True, "GIF": True}


def _short(value):
    if isinstance(value, bytes | bytearray):
        return f"<{len(value)} bytes>"
    if isinstance(value, str | int | float | bool) or value is None:
        return value if not isinstance(value, str) or len(value) <= 80 else value[:77] + "..."
    if isinstance(value, tuple) and all(isinstance(v, int | float) for v in value):
        return tuple(float(v) if not isinstance(v, int) else v for v in value)
    return type(value).__name__


def image_info(path: str | os.PathLike) -> dict:
    """What an image file holds, read from its header with Pillow (the formats table).

    **Arguments:**

    - `path`: an image file.

    **Returns:**

    A dict with

    - `format` (`"PNG"`, `"JPEG"`, ...), `width`, `height`, `mode` (Pillow's mode, e.g.
      `"RGB"`, `"P"` for palette, `"L"` for grey), `channels`,
    - `bit_depth` (bits per sample), `bits_per_pixel` (the colour depth; for a palette
      image the bits of an index), `palette_colours` (entries in the palette, 0 if none),
    - `compression` (e.g. `"deflate"`, `"LZW"`, `"DCT baseline"`, `"raw"`, `"tiff_lzw"`),
      `lossless` (`False` only for JPEG data),
    - `transparency` (alpha channel or a transparent palette entry), `frames`, `animated`,
    - `metadata` (the file's extra info: dpi, gamma, comments, ICC profile size, ...),
    - `file_size` (bytes), `raw_size` (bytes of the uncompressed 8-bit pixels of all
      frames) and `compression_ratio` (`raw_size / file_size`).
    """
    from PIL import Image

    path = pathlib.Path(path)
    file_size = path.stat().st_size
    with Image.open(path) as im:
        fmt = im.format
        width, height = im.size
        mode = im.mode
        frames = int(getattr(im, "n_frames", 1))
        info = dict(im.info)
        bands = len(im.getbands())
        palette_colours = 0
        if mode in ("P", "PA") and im.palette is not None:
            colors = im.getpalette() or []
            palette_colours = len(colors) // 3
        if fmt == "JPEG":
            compression = "DCT progressive" if info.get("progressive") else "DCT baseline"
        elif fmt == "PNG":
            compression = "deflate"
        elif fmt == "GIF":
            compression = "LZW"
        elif fmt == "BMP":
            code = info.get("compression", 0)
            compression = {0: "raw", 1: "RLE8", 2: "RLE4", 3: "bitfields"}.get(code, str(code))
        elif fmt == "TIFF":
            compression = str(info.get("compression", "raw"))
        else:
            compression = str(info.get("compression", "unknown"))
    transparency = "A" in mode or mode.endswith("a") or "transparency" in info
    bit_depth = _MODE_BITS.get(mode, 8)
    channels = 1 if mode in ("P", "1") else bands
    bits_per_pixel = bit_depth * (1 if mode in ("P", "1") else bands)
    lossless = _LOSSLESS.get(fmt, True) and compression not in ("jpeg", "webp")
    skip = {"transparency", "compression", "progressive", "progression"}
    metadata = {k: _short(v) for k, v in info.items() if k not in skip}
    raw_size = width * height * max(1, math.ceil(bits_per_pixel / 8)) * frames
    return {
        "format": fmt,
        "width": width,
        "height": height,
        "mode": mode,
        "channels": channels,
        "bit_depth": bit_depth,
        "bits_per_pixel": bits_per_pixel,
        "palette_colours": palette_colours,
        "compression": compression,
        "lossless": bool(lossless),
        "transparency": bool(transparency),
        "frames": frames,
        "animated": frames > 1,
        "metadata": metadata,
        "file_size": file_size,
        "raw_size": raw_size,
        "compression_ratio": raw_size / file_size,
    }


# --------------------------------------------------------------------------------------
# Raster versus vector
# --------------------------------------------------------------------------------------


def _colour(value, name: str) -> tuple[float, float, float] | None:
    if value is None:
        return None
    rgb = tuple(float(v) for v in np.broadcast_to(np.asarray(value, dtype=float), (3,)))
    if not all(0.0 <= v <= 1.0 for v in rgb):
        raise ValueError(f"`{name}` must be an RGB colour with entries in [0, 1], got {value!r}")
    return rgb


class Polygon(eqx.Module):
    """A closed polygon in pixel coordinates (y up), filled with the even-odd rule.

    **Fields:** `points` `(N, 2)` vertices; `fill`, `stroke` RGB colours in [0, 1] or
    `None`; `stroke_width` in pixels (round joins).
    """

    points: Float[Array, "N 2"]
    fill: tuple | None = eqx.field(static=True, default=(0.0, 0.0, 0.0))
    stroke: tuple | None = eqx.field(static=True, default=None)
    stroke_width: float = eqx.field(static=True, default=1.0)

    def __check_init__(self):
        check_last_dim(jnp.asarray(self.points), "points", (2,), "polygon vertices (x, y)")


class Polyline(eqx.Module):
    """An open polyline in pixel coordinates (y up), stroked with round caps and joins.

    **Fields:** `points` `(N, 2)`; `stroke` RGB colour in [0, 1]; `stroke_width` in pixels.
    """

    points: Float[Array, "N 2"]
    stroke: tuple = eqx.field(static=True, default=(0.0, 0.0, 0.0))
    stroke_width: float = eqx.field(static=True, default=1.0)

    def __check_init__(self):
        check_last_dim(jnp.asarray(self.points), "points", (2,), "polyline vertices (x, y)")


class Circle(eqx.Module):
    """A circle in pixel coordinates (y up).

    **Fields:** `center` `(2,)`; `radius`; `fill`, `stroke` RGB colours in [0, 1] or
    `None`; `stroke_width` in pixels.
    """

    center: Float[Array, "2"]
    radius: Float[Array, ""]
    fill: tuple | None = eqx.field(static=True, default=(0.0, 0.0, 0.0))
    stroke: tuple | None = eqx.field(static=True, default=None)
    stroke_width: float = eqx.field(static=True, default=1.0)


def _check_shapes(shapes) -> list:
    if isinstance(shapes, Polygon | Polyline | Circle):
        shapes = [shapes]
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

    - `path`: the `.svg` file to write.
    - `shapes`: `Polygon`, `Polyline` and `Circle` objects, drawn in order (painter's).
    - `shape`: `(H, W)`, the size of the canvas in pixels.
    - `background`: RGB colour in [0, 1] of the canvas, or `None` for transparent.

    **Returns:**

    The path written.
    """
    height, width = static_shape(shape)
    shapes = _check_shapes(shapes)

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
                f'  <polygon points="{xy(s.points)}" fill="{_svg_colour(s.fill)}" '
                f'fill-rule="evenodd" stroke="{_svg_colour(s.stroke)}" '
                f'stroke-width="{s.stroke_width:g}" stroke-linejoin="round"/>'
            )
        elif isinstance(s, Polyline):
            lines.append(
                f'  <polyline points="{xy(s.points)}" fill="none" '
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
    path = pathlib.Path(path)
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


def _inside_evenodd(px, py, points):
    a, b = points, jnp.roll(points, -1, axis=0)
    px, py = px[..., None], py[..., None]
    ay, by = a[:, 1], b[:, 1]
    straddles = (ay > py) != (by > py)
    x_cross = a[:, 0] + (py - ay) * (b[:, 0] - a[:, 0]) / jnp.where(by != ay, by - ay, 1.0)
    return (jnp.sum(straddles & (px < x_cross), axis=-1) % 2) == 1


def rasterize_shapes(
    shapes: Sequence[Polygon | Polyline | Circle],
    shape: tuple[int, int],
    *,
    supersample: int = 4,
    background: tuple = (1.0, 1.0, 1.0),
) -> Float[Array, "H W 3"]:
    """Rasterize vector shapes onto an `(H, W)` pixel grid (the raster side of `write_svg`).

    Every pixel is sampled on a `supersample x supersample` grid of points; each sample
    takes the colour of the last shape covering it (fill by the even-odd rule, strokes
    with round caps and joins), and the pixel is the mean of its samples (box-filter
    anti-aliasing). The coverage is a step function of the shape parameters, so this is
    not differentiable with respect to them (soft rasterization belongs to `gfxlab.render`).

    **Arguments:**

    - `shapes`: `Polygon`, `Polyline` and `Circle` objects in pixel coordinates (y up).
    - `shape`: `(H, W)`.
    - `supersample`: samples per pixel along each axis (static).
    - `background`: RGB colour in [0, 1].

    **Returns:**

    An `(H, W, 3)` float image in [0, 1].
    """
    height, width = static_shape(shape)
    s = static_int(supersample, "supersample", minimum=1)
    shapes = _check_shapes(shapes)
    background = _colour(background, "background")
    for sh in shapes:
        _colour(getattr(sh, "fill", None), "fill")
        _colour(sh.stroke, "stroke")
    return _rasterize(shapes, (height, width), s, background)


@functools.partial(jax.jit, static_argnums=(1, 2, 3))
def _rasterize(shapes, shape, s, background):
    height, width = shape
    offsets = (jnp.arange(s) + 0.5) / s - 0.5
    xs = (jnp.arange(width)[:, None] + offsets[None, :]).reshape(-1)
    ys = (height - 1 - jnp.arange(height)[:, None] - offsets[None, :]).reshape(-1)
    px, py = jnp.meshgrid(xs, ys)
    dtype = jnp.result_type(float)
    canvas = jnp.broadcast_to(jnp.asarray(_colour(background, "background"), dtype), (*px.shape, 3))

    def paint(canvas, mask, rgb):
        if rgb is None:
            return canvas
        return jnp.where(mask[..., None], jnp.asarray(_colour(rgb, "colour"), dtype), canvas)

    for sh in shapes:
        if isinstance(sh, Circle):
            center = as_float(sh.center, "center")
            d = jnp.hypot(px - center[0], py - center[1])
            canvas = paint(canvas, d <= sh.radius, sh.fill)
            canvas = paint(canvas, jnp.abs(d - sh.radius) <= sh.stroke_width / 2, sh.stroke)
            continue
        pts = as_float(sh.points, "points")
        if isinstance(sh, Polygon):
            canvas = paint(canvas, _inside_evenodd(px, py, pts), sh.fill)
            a, b = pts, jnp.roll(pts, -1, axis=0)
        else:
            a, b = pts[:-1], pts[1:]
        if sh.stroke is not None and a.shape[0] > 0:
            canvas = paint(
                canvas, _segment_distance(px, py, a, b) <= sh.stroke_width / 2, sh.stroke
            )
    return canvas.reshape(height, s, width, s, 3).mean(axis=(1, 3))


# --------------------------------------------------------------------------------------
# Selection networks
# --------------------------------------------------------------------------------------


@functools.cache
def _sorting_network(n: int) -> tuple[tuple[int, int], ...]:
    """Batcher's odd-even merge sort on `n` wires as compare-exchange pairs `(lo, hi)`.

    Built for the next power of two; comparators that touch a wire >= n are dropped,
    which is exact because such a wire would hold +inf and never move.
    """
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return tuple(pairs)


def selection_network(n: int, ranks: Sequence[int]) -> tuple[tuple[bool, bool, int, int], ...]:
    """A compare-exchange network that leaves the values of `ranks` (0 = smallest) of `n`
    inputs on wires `ranks`.

    Batcher's odd-even merge sort, pruned backwards from the wanted outputs: a comparator
    none of whose outputs is needed is dropped, one with a single needed output becomes a
    lone `minimum` or `maximum`.

    **Arguments:**

    - `n`: number of inputs.
    - `ranks`: the wanted order statistics.

    **Returns:**

    Operations `(keep_min, keep_max, lo, hi)`: `wire[lo] = min(wire[lo], wire[hi])` if
    `keep_min`, `wire[hi] = max(...)` if `keep_max` (both from the old values).
    """
    n = static_int(n, "n", minimum=1)
    ranks = tuple(sorted({static_int(r, "ranks") for r in ranks}))
    if not ranks or any(not 0 <= r < n for r in ranks):
        raise ValueError(f"`ranks` must be in 0..{n - 1}, got {ranks}")
    return _selection_network(n, ranks)


@functools.cache
def _selection_network(n: int, ranks: tuple[int, ...]) -> tuple[tuple[bool, bool, int, int], ...]:
    # The minimum or the maximum alone: a chain of n - 1 comparisons beats any pruned sort.
    if ranks == (0,):
        return tuple((True, False, 0, i) for i in range(1, n))
    if ranks == (n - 1,):
        return tuple((False, True, i, n - 1) for i in range(n - 1))
    needed = set(ranks)
    ops = []
    for lo, hi in reversed(_sorting_network(n)):
        keep_min, keep_max = lo in needed, hi in needed
        if keep_min or keep_max:
            ops.append((keep_min, keep_max, lo, hi))
            needed |= {lo, hi}
    return tuple(reversed(ops))


def _run_network(ops, wires: list) -> list:
    wires = list(wires)
    for keep_min, keep_max, lo, hi in ops:
        a, b = wires[lo], wires[hi]
        if keep_min:
            wires[lo] = jnp.minimum(a, b)
        if keep_max:
            wires[hi] = jnp.maximum(a, b)
    return wires


def _middle_ranks(n: int) -> tuple[int, ...]:
    return (n // 2,) if n % 2 else (n // 2 - 1, n // 2)


def _combine_middle(values: list, dtype):
    """The median from its middle order statistics: one value, or the mean of two."""
    if len(values) == 1:
        return values[0]
    out = jnp.result_type(dtype, float) if not jnp.issubdtype(dtype, jnp.floating) else dtype
    a, b = (v.astype(out) for v in values)
    return a / 2 + b / 2


def median(values: Shaped[Array, "*batch n"], *, axis: int = -1) -> Shaped[Array, "*batch"]:
    """The median along `axis`, by a selection network (not a sort).

    For an odd count it is the middle value (same dtype as `values`); for an even count
    `2K` it is the mean of the K-th and (K+1)-th smallest values (a float), the rule the
    seed gives for even windows.

    **Arguments:**

    - `values`: an array with at least one entry along `axis`.
    - `axis`: the axis to reduce.

    **Returns:**

    `values` with `axis` removed.
    """
    values = jnp.asarray(values)
    if values.ndim == 0:
        raise ValueError("`values` must have at least one axis, got a scalar")
    values = jnp.moveaxis(values, axis, -1)
    n = values.shape[-1]
    if n == 0:
        raise ValueError("`values` must be non-empty along `axis`")
    ranks = _middle_ranks(n)
    wires = _run_network(selection_network(n, ranks), [values[..., i] for i in range(n)])
    return _combine_middle([wires[r] for r in ranks], values.dtype)


def median_of_sum(x, y) -> tuple[jax.Array, jax.Array]:
    """`(median(x + y), median(x) + median(y))`: the median is not linear.

    For the signals `x = (1, 5, 2)` and `y = (4, 0, 0)`: `x + y = (5, 5, 2)`, so
    `median{x + y} = 5`, but `median{x} + median{y} = 2 + 0 = 2`.

    **Arguments:**

    - `x`, `y`: two signals of the same shape `(..., n)`.

    **Returns:**

    The two sides of the (generally false) identity `median{x + y} = median{x} + median{y}`.
    """
    x, y = jnp.asarray(x), jnp.asarray(y)
    if x.shape != y.shape:
        raise ValueError(f"`x` and `y` must have one shape, got {x.shape} and {y.shape}")
    return median(x + y), median(x) + median(y)


# --------------------------------------------------------------------------------------
# Filters
# --------------------------------------------------------------------------------------


def _check_filter_image(image, name: str = "image") -> jax.Array:
    arr = jnp.asarray(image)
    if arr.ndim not in (2, 3):
        raise ValueError(f"`{name}` must have shape (H, W) or (H, W, C), got shape {arr.shape}")
    if jnp.issubdtype(arr.dtype, jnp.complexfloating):
        raise TypeError(f"`{name}` must be real, got dtype {arr.dtype}")
    return arr


def _check_mode(mode) -> str:
    if mode not in MODES:
        raise ValueError(f"`mode` must be one of {MODES}, got {mode!r}")
    return mode


def _window_size(size) -> tuple[int, int]:
    if isinstance(size, Sequence) and not isinstance(size, str):
        if len(size) != 2:
            raise ValueError(f"`size` must be an int or a pair (rows, cols), got {size!r}")
        return static_int(size[0], "size[0]", minimum=1), static_int(size[1], "size[1]", minimum=1)
    k = static_int(size, "size", minimum=1)
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
    """The plus-shaped footprint: `radius=1` is the 5-pixel cross of the seed.

    **Returns:** a boolean `(2r + 1, 2r + 1)` array, True on the middle row and column.
    """
    r = static_int(radius, "radius", minimum=0)
    fp = np.zeros((2 * r + 1, 2 * r + 1), dtype=bool)
    fp[r, :] = fp[:, r] = True
    return fp


def _check_footprint(footprint) -> np.ndarray:
    if isinstance(footprint, jax.core.Tracer):
        raise TypeError("`footprint` sets the window, so it must be a concrete array, not traced")
    fp = np.asarray(footprint)
    if fp.dtype != np.bool_:
        raise TypeError(f"`footprint` must be a boolean array, got dtype {fp.dtype}")
    if fp.ndim != 2:
        raise ValueError(f"`footprint` must be 2-D (rows, cols), got shape {fp.shape}")
    if not fp.any():
        raise ValueError("`footprint` must select at least one pixel (it is all False)")
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
    column_ops = selection_network(kh, column_ranks)
    row_ops = {i: selection_network(kw, r) for i, r in row_ranks.items()}
    final_ranks = tuple(r - below for r in ranks)
    final_ops = selection_network(len(survivors), final_ranks)
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
    wires = _run_network(selection_network(len(views), ranks), views)
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
    values (the seed's rule; SciPy instead returns the (K+1)-th): a float image, since the
    mean of two integers can be a half-integer (round it yourself if you need integers).

    It is computed with a pruned compare-exchange network on shifted views of the padded
    image, never a sort of every window. Full rectangles first sort each column (shared by
    neighbouring windows), then the rows, then select among the few entries that can still
    be the median (for 3x3: `med3(max of lows, med3 of middles, min of highs)`). The
    gradient flows to the selected pixel (split in half at exact ties).

    **Arguments:**

    - `image`: `(H, W)` or `(H, W, C)`, any real dtype.
    - `size`: window size, an int (square) or `(rows, cols)`; ignored if `footprint` is given.
    - `footprint`: a boolean `(rows, cols)` array selecting the window pixels, e.g.
      `cross_footprint()` (the 5-pixel cross).
    - `mode`: border handling, one of `MODES`: "reflect", "constant", "nearest", "mirror",
      "wrap" (as in `scipy.ndimage`).
    - `cval`: the value outside the image for `mode="constant"`.

    **Returns:**

    The filtered image, same shape; same dtype for odd windows, float for even windows.
    """
    image = _check_filter_image(image)
    mode = _check_mode(mode)
    if footprint is None:
        kh, kw = _window_size(size)
        footprint = np.ones((kh, kw), dtype=bool)
    else:
        footprint = _check_footprint(footprint)
    ranks = _middle_ranks(int(footprint.sum()))
    # Channels first, so that shifted views run along contiguous rows.
    planes = jnp.moveaxis(image, -1, 0) if image.ndim == 3 else image
    padded = _pad(planes, footprint.shape, mode, cval)
    values = _window_ranks(padded, image.shape[:2], footprint, ranks)
    if image.ndim == 3:
        values = [jnp.moveaxis(v, 0, -1) for v in values]
    return _combine_middle(values, image.dtype)


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
    - `size`: window size, an int or `(rows, cols)`.
    - `mode`, `cval`: border handling as in `median_filter`.

    **Returns:**

    The filtered float image.
    """
    image = as_float(_check_filter_image(image), "image")
    mode = _check_mode(mode)
    kh, kw = _window_size(size)
    return _mean_filter(image, jnp.asarray(cval), size=(kh, kw), mode=mode)


@functools.partial(jax.jit, static_argnames=("size", "mode"))
def _mean_filter(image, cval, *, size, mode):
    kh, kw = size
    kernels = ([1.0 / kh] * kh, [1.0 / kw] * kw)
    return _on_planes(
        lambda x: _correlate_separable(_pad(x, (kh, kw), mode, cval), image.shape[:2], kernels),
        image,
    )


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
    - `sigma`: standard deviation in pixels (> 0), one value or `(rows, cols)`.
    - `truncate`: radius in units of sigma when `radius` is not given.
    - `radius`: kernel radius, an int or `(rows, cols)` (static).
    - `mode`, `cval`: border handling as in `median_filter`.

    **Returns:**

    The blurred float image.
    """
    image = as_float(_check_filter_image(image), "image")
    mode = _check_mode(mode)
    traced = isinstance(sigma, jax.core.Tracer)
    if not traced:
        concrete = np.broadcast_to(np.asarray(sigma, dtype=float), (2,))
        if not np.all(concrete > 0):
            raise ValueError(f"`sigma` must be > 0, got {sigma}")
    if radius is None:
        if traced:
            raise TypeError("a traced `sigma` needs a static `radius=` (the kernel size)")
        radii = tuple(int(float(truncate) * float(s) + 0.5) for s in concrete)
    else:
        radii = (radius, radius) if not isinstance(radius, Sequence) else tuple(radius)
        if len(radii) != 2:
            raise ValueError(f"`radius` must be an int or a pair (rows, cols), got {radius!r}")
        radii = tuple(static_int(r, "radius", minimum=0) for r in radii)
    sigma = jnp.broadcast_to(as_float(sigma, "sigma").astype(image.dtype), (2,))
    if traced:
        sigma = value_error_if(sigma, ~(sigma > 0), "`sigma` must be > 0")
    return _gaussian_filter(image, sigma, jnp.asarray(cval), radii=radii, mode=mode)


@functools.partial(jax.jit, static_argnames=("radii", "mode"))
def _gaussian_filter(image, sigma, cval, *, radii, mode):
    kernels = []
    for axis, r in enumerate(radii):
        x = jnp.arange(-r, r + 1, dtype=image.dtype)
        w = jnp.exp(-0.5 * (x / sigma[axis]) ** 2)
        kernels.append(list(w / jnp.sum(w)))
    window = (2 * radii[0] + 1, 2 * radii[1] + 1)
    return _on_planes(
        lambda x: _correlate_separable(_pad(x, window, mode, cval), image.shape[:2], kernels),
        image,
    )


# --------------------------------------------------------------------------------------
# Test pictures
# --------------------------------------------------------------------------------------


def add_salt_and_pepper(
    image: Float[Array, "H W *C"], *, amount: float = 0.05, key: jax.Array
) -> Float[Array, "H W *C"]:
    """Impulse noise: a fraction `amount` of pixels set to 0 or 1 (half each), all
    channels of a pixel together.

    **Arguments:**

    - `image`: float image in [0, 1], `(H, W)` or `(H, W, C)`.
    - `amount`: the expected fraction of corrupted pixels, in [0, 1].
    - `key`: a `jax.random` key.

    **Returns:**

    The noisy image (same shape and dtype).
    """
    image = as_float(_check_filter_image(image), "image")
    amount = value_error_if(
        amount,
        (jnp.asarray(amount) < 0) | (jnp.asarray(amount) > 1),
        f"`amount` must be in [0, 1], got {amount}",
    )
    k1, k2 = jax.random.split(key)
    u = jax.random.uniform(k1, image.shape[:2], dtype=image.dtype)
    salt = jax.random.bernoulli(k2, 0.5, image.shape[:2])
    hit, salt = u < amount, salt
    if image.ndim == 3:
        hit, salt = hit[..., None], salt[..., None]
    return jnp.where(hit, jnp.where(salt, 1.0, 0.0).astype(image.dtype), image)


def synthetic_scene(shape: tuple[int, int] = (256, 256), *, seed: int = 0) -> np.ndarray:
    """A procedural, photograph-like RGB scene: sky, sun, hills, a house, a tree, grass
    texture and sensor noise. Deterministic for a given `shape` and `seed` (NumPy only).

    `data/images/scene.png` is `synthetic_scene()` written by `write_image`.

    **Returns:**

    A float64 NumPy array `(H, W, 3)` in [0, 1].
    """
    height, width = static_shape(shape)
    rng = np.random.default_rng(static_int(seed, "seed", minimum=0))
    v, u = np.meshgrid(np.linspace(1, 0, height), np.linspace(0, 1, width), indexing="ij")

    def smooth_noise(cells):
        """Bilinearly interpolated value noise on a `cells x cells` grid."""
        grid = rng.random((cells + 1, cells + 1))
        gy, gx = v * cells, u * cells
        i0 = np.minimum(gy.astype(int), cells - 1)
        j0 = np.minimum(gx.astype(int), cells - 1)
        fy, fx = gy - i0, gx - j0
        fy, fx = fy * fy * (3 - 2 * fy), fx * fx * (3 - 2 * fx)
        top = grid[i0, j0] * (1 - fx) + grid[i0, j0 + 1] * fx
        bottom = grid[i0 + 1, j0] * (1 - fx) + grid[i0 + 1, j0 + 1] * fx
        return top * (1 - fy) + bottom * fy

    clouds = 0.5 * smooth_noise(6) + 0.3 * smooth_noise(14) + 0.2 * smooth_noise(30)
    sky = np.stack([0.35 + 0.45 * (1 - v), 0.55 + 0.35 * (1 - v), 0.95 - 0.1 * (1 - v)], -1)
    img = sky + 0.35 * np.clip(clouds - 0.5, 0, 1)[..., None]
    sun_d = np.hypot((u - 0.78) * width / height, v - 0.82)
    img += np.clip(1.0 - sun_d / 0.08, 0, 1)[..., None] ** 0.5 * np.array([0.6, 0.5, 0.2])
    img += 0.25 * np.exp(-((sun_d / 0.2) ** 2))[..., None] * np.array([1.0, 0.8, 0.4])
    far = 0.45 + 0.06 * np.sin(7 * u + 1) + 0.03 * np.sin(23 * u) + 0.03 * smooth_noise(10)
    img = np.where((v < far)[..., None], np.array([0.35, 0.45, 0.6]) + 0.1 * v[..., None], img)
    near = 0.3 + 0.08 * np.sin(4 * u + 2) + 0.04 * smooth_noise(8)
    texture = 0.6 * smooth_noise(40) + 0.4 * rng.random((height, width))
    grass = np.stack([0.2 + 0.15 * texture, 0.45 + 0.25 * texture, 0.12 + 0.08 * texture], -1)
    img = np.where((v < near)[..., None], grass * (0.7 + 0.6 * v[..., None]), img)
    # A house: wall, roof, door and window.
    wall = (u > 0.18) & (u < 0.42) & (v > 0.22) & (v < 0.4)
    roof = (v >= 0.4) & (v < 0.4 + 0.16 - np.abs(u - 0.3) * 1.1) & (u > 0.15) & (u < 0.45)
    img = np.where(
        wall[..., None], np.array([0.85, 0.78, 0.65]) - 0.05 * smooth_noise(50)[..., None], img
    )
    img = np.where(
        roof[..., None], np.array([0.6, 0.15, 0.1]) + 0.08 * smooth_noise(60)[..., None], img
    )
    door = (u > 0.27) & (u < 0.32) & (v > 0.22) & (v < 0.33)
    window = (u > 0.35) & (u < 0.4) & (v > 0.3) & (v < 0.36)
    img = np.where(door[..., None], np.array([0.35, 0.2, 0.1]), img)
    img = np.where(window[..., None], np.array([0.9, 0.85, 0.4]), img)
    # A tree: trunk and a textured round crown.
    trunk = (np.abs(u - 0.7) < 0.015) & (v > 0.2) & (v < 0.36)
    crown_d = np.hypot((u - 0.7) * width / height, v - 0.42)
    leaves = 0.5 * smooth_noise(35) + 0.5 * rng.random((height, width))
    img = np.where(trunk[..., None], np.array([0.3, 0.2, 0.1]), img)
    crown = crown_d < 0.1 + 0.015 * smooth_noise(12)
    img = np.where(
        crown[..., None],
        np.stack([0.1 + 0.1 * leaves, 0.3 + 0.3 * leaves, 0.08 + 0.05 * leaves], -1),
        img,
    )
    img += 0.012 * rng.standard_normal((height, width, 3))
    return np.clip(img, 0.0, 1.0)
