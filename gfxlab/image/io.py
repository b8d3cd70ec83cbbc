"""Image files: read, write and describe PNG, JPEG, BMP, TIFF and GIF with Pillow.

Pillow is imported only when a file is touched. At the file boundary samples are
`uint8` (`write_image` clips float images to [0, 1], scales them by 255 and rounds
half to even); `read_image` returns floats
in [0, 1] by default. A file Pillow cannot read (not an image, truncated, corrupt, or
larger than Pillow's decompression-bomb limit) raises `ImageFileError` naming the file.
"""

from __future__ import annotations

import contextlib
import math
import os
import pathlib
import struct
from collections.abc import Sequence

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Shaped

from .._checks import static_int
from .._pixels import to_float, to_uint8

__all__ = ["FORMATS", "ImageFileError", "read_image", "write_image", "image_info"]

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


class ImageFileError(ValueError):
    """A file that is not a readable image: unidentified format, truncated or corrupt
    data, or more pixels than Pillow's decompression-bomb limit
    (`PIL.Image.MAX_IMAGE_PIXELS`). The message names the file; the original Pillow
    error is chained as `__cause__`."""


def _check_path(path, name: str = "path") -> pathlib.Path:
    if path is None:
        raise TypeError(f"`{name}` must be a file path (str or os.PathLike), got None")
    if not isinstance(path, str | os.PathLike):
        raise TypeError(f"`{name}` must be a file path (str or os.PathLike), got {path!r}")
    return pathlib.Path(path)


@contextlib.contextmanager
def _pillow_errors(path: pathlib.Path):
    """Turn Pillow's many failure modes on a bad file into one `ImageFileError`."""
    from PIL import Image

    try:
        yield
    except (FileNotFoundError, IsADirectoryError, PermissionError):
        raise
    except Image.DecompressionBombError as err:
        raise ImageFileError(
            f"{os.fspath(path)!r} has more pixels than Pillow's decompression-bomb limit "
            f"(PIL.Image.MAX_IMAGE_PIXELS = {Image.MAX_IMAGE_PIXELS}): {err}"
        ) from err
    except Image.UnidentifiedImageError as err:
        raise ImageFileError(
            f"{os.fspath(path)!r} is not an image file Pillow can identify"
        ) from err
    except (
        OSError,
        SyntaxError,
        TypeError,
        ValueError,
        EOFError,
        struct.error,
        IndexError,
        KeyError,
        ZeroDivisionError,
        OverflowError,
        MemoryError,
    ) as err:
        raise ImageFileError(
            f"{os.fspath(path)!r} is not a readable image (truncated or corrupt data): "
            f"{type(err).__name__}: {err}"
        ) from err


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

    path = _check_path(path)
    fmt = _format_for(path, format)
    frames = list(image) if isinstance(image, list | tuple) else [image]
    if not frames:
        raise ValueError("`image` is an empty list of frames")
    arrays = [to_uint8(f, "image") for f in frames]
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


def _load_frame(im, frame: int) -> tuple[np.ndarray, str]:
    """The samples of frame `frame` of an open Pillow image, and its original mode."""
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
    return np.asarray(im), mode


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

    **Raises:** `FileNotFoundError` for a missing file; `ImageFileError` (a `ValueError`
    naming the file) for a file Pillow cannot read: not an image
    (`UnidentifiedImageError`), over the decompression-bomb limit
    (`DecompressionBombError`), truncated or corrupt data (including the `TypeError`s
    of bad TIFF tags).
    """
    from PIL import Image

    path = _check_path(path)
    frame = static_int(frame, "frame", minimum=0)
    with _pillow_errors(path), Image.open(path) as im:
        frames = getattr(im, "n_frames", 1)
        if frame < frames:
            arr, mode = _load_frame(im, frame)
    if frame >= frames:
        raise ValueError(f"`frame` must be < {frames} (the file has {frames}), got {frame}")
    if arr.dtype == np.uint8:  # the file-boundary rule of `_pixels` (8 bits)
        return to_float(arr) if as_float else arr
    if arr.dtype in (np.uint16, np.dtype(">u2"), np.int32) and mode.startswith("I"):
        arr = arr.astype(np.uint16)  # 16-bit files: the same rule, 65535 for 255
        return jnp.asarray(arr / 65535.0, dtype=jnp.result_type(float)) if as_float else arr
    if np.issubdtype(arr.dtype, np.floating):
        return jnp.asarray(arr, dtype=jnp.result_type(float)) if as_float else arr
    raise ImageFileError(f"unsupported image mode {mode!r} in {os.fspath(path)!r}")


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
      image the bits of an index), `palette_colors` (entries in the palette, 0 if none),
    - `compression` (e.g. `"deflate"`, `"LZW"`, `"DCT baseline"`, `"raw"`, `"tiff_lzw"`),
      `lossless` (`False` only for JPEG data),
    - `transparency` (alpha channel or a transparent palette entry), `frames`, `animated`,
    - `metadata` (the file's extra info: dpi, gamma, comments, ICC profile size, ...),
    - `file_size` (bytes), `raw_size` (bytes of the uncompressed 8-bit pixels of all
      frames) and `compression_ratio` (`raw_size / file_size`).
    """
    from PIL import Image

    path = _check_path(path)
    file_size = path.stat().st_size
    with _pillow_errors(path), Image.open(path) as im:
        fmt = im.format
        width, height = im.size
        mode = im.mode
        frames = int(getattr(im, "n_frames", 1))
        info = dict(im.info)
        bands = len(im.getbands())
        palette_colors = 0
        if mode in ("P", "PA") and im.palette is not None:
            colors = im.getpalette() or []
            palette_colors = len(colors) // 3
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
        "palette_colors": palette_colors,
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
