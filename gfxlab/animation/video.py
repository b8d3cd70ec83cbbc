"""Video files: write an animation, and read a container's structure ourselves.

`save_animation` encodes frames with the ffmpeg binary bundled by `imageio-ffmpeg`
(MP4/MOV with H.264, AVI with Motion-JPEG, FLV with Sorenson H.263, WebM with VP8, WMV
with Windows Media Video 8 in ASF) or with Pillow (animated GIF).

`container_info` parses the container format directly, without ffmpeg: RIFF chunks
(AVI), ISO base media boxes (MP4, MOV), FLV tags, EBML elements (WebM), ASF objects
(WMV) and GIF blocks. It reports the codec, frame count, duration, frame size and the
tree of boxes/chunks, which is what distinguishes the formats: the container is the
box that holds the compressed streams, the codec is how each frame is compressed.
"""

from __future__ import annotations

import math
import os
import struct
import warnings

import jax
import numpy as np

from .._pixels import to_uint8
from ._containers import ContainerInfo, Node, _avi, _iso_bmff, format_tree
from ._streams import _ASF_HEADER, _asf, _ebml, _flv, _gif

__all__ = ["FORMATS", "save_animation", "container_info", "ContainerInfo", "Node", "format_tree"]

#: Formats `save_animation` writes: suffix -> (ffmpeg muxer, codec, pixel format, label).
FORMATS = {
    "mp4": ("mp4", "libx264", "yuv420p", "H.264 in MPEG-4 Part 14"),
    "mov": ("mov", "libx264", "yuv420p", "H.264 in QuickTime"),
    "avi": ("avi", "mjpeg", "yuvj420p", "Motion JPEG in RIFF/AVI"),
    "flv": ("flv", "flv", "yuv420p", "Sorenson H.263 in Flash Video"),
    "webm": ("webm", "libvpx", "yuv420p", "VP8 in WebM (Matroska)"),
    "wmv": ("asf", "wmv2", "yuv420p", "Windows Media Video 8 in ASF"),
    "gif": (None, "gif", None, "LZW palette images in GIF89a (Pillow)"),
}


def _path(path, name: str = "path") -> str:
    if path is None or not isinstance(path, str | bytes | os.PathLike):
        raise TypeError(f"`{name}` must be a file path (str or os.PathLike), got {path!r}")
    return os.fsdecode(path)


def _to_uint8_frames(frames) -> np.ndarray:
    if frames is None:
        raise TypeError("`frames` must be an array of frames, got None")
    arr = np.asarray(jax.device_get(frames)) if isinstance(frames, jax.Array) else frames
    arr = np.asarray(arr)
    if arr.ndim not in (3, 4) or arr.shape[0] < 1:
        raise ValueError(
            f"`frames` must be (T, H, W) or (T, H, W, C) with C in 1, 3, 4 and T >= 1, got "
            f"shape {arr.shape}"
        )
    if arr.ndim == 3:
        arr = arr[..., None]
    if arr.shape[-1] not in (1, 3, 4):
        raise ValueError(f"`frames` must have 1, 3 or 4 channels, got shape {arr.shape}")
    if arr.dtype != np.uint8 and not np.issubdtype(arr.dtype, np.floating):
        raise TypeError(f"`frames` must be uint8 or floats in [0, 1], got dtype {arr.dtype}")
    # The one float <-> uint8 conversion at file boundaries (NaN/inf are errors).
    arr = to_uint8(arr, "frames")
    if arr.shape[-1] == 1:
        arr = np.repeat(arr, 3, axis=-1)
    return np.ascontiguousarray(arr[..., :3])


def save_animation(
    frames, path, *, fps: float = 24.0, format: str | None = None, quality: int | None = None
) -> str:
    """Write frames as a video (or animated GIF).

    **Arguments:**

    - `frames`: `(T, H, W)` or `(T, H, W, C)`, uint8 or floats in `[0, 1]` (alpha is
      dropped). Codecs with 4:2:0 chroma need even sizes: odd sizes are padded by
      repeating the last row/column.
    - `path`: the output file.
    - `fps`: frames per second (> 0). GIF stores delays in 1/100 s, so its rate is
      rounded to that.
    - `format`: one of `FORMATS` (`"mp4"`, `"mov"`, `"avi"`, `"flv"`, `"webm"`, `"wmv"`,
      `"gif"`); default from the file suffix.
    - `quality`: codec quality 1..10 (ffmpeg formats), default the codec's own.

    **Returns:** the path written, as a string.
    """
    path = _path(path)
    if format is None:
        format = os.path.splitext(path)[1].lower().lstrip(".")
    format = str(format).lower()
    if format not in FORMATS:
        raise ValueError(
            f"`format` must be one of {sorted(FORMATS)} (or a path with such a "
            f"suffix), got {format!r}"
        )
    if isinstance(fps, bool) or not isinstance(fps, int | float | np.integer | np.floating):
        raise TypeError(f"`fps` must be a positive number, got {fps!r}")
    if not (math.isfinite(fps) and fps > 0):
        raise ValueError(f"`fps` must be a positive, finite number, got {fps!r}")
    if quality is not None and (
        isinstance(quality, bool)
        or not isinstance(quality, int | np.integer)
        or not 1 <= quality <= 10
    ):
        raise ValueError(f"`quality` must be None or an int in 1..10, got {quality!r:.40}")
    frames = _to_uint8_frames(frames)
    if format == "gif":
        _save_gif(frames, path, fps)
        return path
    muxer, codec, pix_fmt, _ = FORMATS[format]
    if pix_fmt.endswith("420p"):
        pad_h, pad_w = frames.shape[1] % 2, frames.shape[2] % 2
        frames = np.pad(frames, ((0, 0), (0, pad_h), (0, pad_w), (0, 0)), mode="edge")
    import imageio_ffmpeg

    params = ["-f", muxer]
    if codec == "libvpx":
        params += ["-deadline", "realtime", "-b:v", "1M"]
    with warnings.catch_warnings():
        # JAX warns on every fork; ffmpeg runs as a separate process (fork + exec), which
        # is safe.
        warnings.filterwarnings("ignore", message=r"os\.fork\(\) was called")
        _encode(imageio_ffmpeg, frames, path, fps, codec, pix_fmt, quality, params)
    return path


def _encode(imageio_ffmpeg, frames, path, fps, codec, pix_fmt, quality, params):
    _, h, w, _ = frames.shape
    writer = imageio_ffmpeg.write_frames(
        path,
        (w, h),
        fps=fps,
        codec=codec,
        pix_fmt_out=pix_fmt,
        quality=quality,
        macro_block_size=1,
        output_params=params,
        ffmpeg_log_level="error",
    )
    writer.send(None)
    try:
        for frame in frames:
            writer.send(frame.tobytes())
    finally:
        writer.close()


def _save_gif(frames: np.ndarray, path: str, fps: float) -> None:
    from PIL import Image

    delay_ms = max(10, int(round(100.0 / fps)) * 10)
    images = [Image.fromarray(f) for f in frames]
    # optimize=False and disposal=1 keep one image block per frame, even if two frames
    # happen to be equal.
    images[0].save(
        path,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=delay_ms,
        loop=0,
        optimize=False,
        disposal=1,
    )


# ------------------------------------------------------------ container parsing


def container_info(path) -> ContainerInfo:
    """Parse a video container's structure (no ffmpeg): codec, frames, duration, size.

    Recognised by magic bytes: RIFF/AVI, ISO base media (MP4, MOV: `ftyp` box), FLV,
    EBML (WebM/Matroska), ASF (WMV) and GIF.

    **Returns:** a `ContainerInfo`. **Raises:** `ValueError` for an unknown or damaged file.
    """
    path = _path(path)
    with open(path, "rb") as fh:
        data = fh.read()
    head = data[:16]
    try:
        if head[:4] == b"RIFF" and head[8:12] == b"AVI ":
            return _avi(data)
        if head[4:8] in (b"ftyp", b"moov", b"mdat", b"wide", b"free"):
            return _iso_bmff(data)
        if head[:3] == b"FLV":
            return _flv(data)
        if head[:4] == b"\x1a\x45\xdf\xa3":
            return _ebml(data)
        if head[:16] == _ASF_HEADER:
            return _asf(data)
        if head[:6] in (b"GIF87a", b"GIF89a"):
            return _gif(data)
    except (
        struct.error,
        IndexError,
        KeyError,
        StopIteration,  # a required chunk/object (avih, FileProperties...) is missing
        UnicodeDecodeError,
        ValueError,
        OverflowError,
        ZeroDivisionError,
    ) as err:
        raise ValueError(f"{path!r}: damaged or truncated container ({err})") from err
    raise ValueError(
        f"{path!r} is not a recognised video container (AVI, MP4/MOV, FLV, WebM, WMV/ASF or "
        f"GIF); it starts with {head[:12]!r}"
    )
