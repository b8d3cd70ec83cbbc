"""Baseline JFIF files: `encode` (bit-exact with libjpeg-turbo / Pillow) and `decode`.

The encoder (`_encoder`) runs libjpeg's integer pipeline on all blocks at once and
turns every coefficient slot into at most one Huffman event (a DC difference, a ZRL,
a run/size code with its extra bits, an EOB), all static shapes: NumPy for small
images, compiled XLA programs for large ones. NumPy then drops the empty slots,
concatenates the bits into 32-bit words and 0xFF-stuffs the bytes.

The decoder lives in `_decoder` (markers, reconstruction) and `_entropy` (Huffman);
`decode` and `JPEGError` are re-exported here.
"""

from __future__ import annotations

import functools

import numpy as np

from gfxlab._checks import is_traced
from gfxlab._pixels import to_uint8
from gfxlab.jpeg import _encoder as E
from gfxlab.jpeg import _libjpeg as L
from gfxlab.jpeg._decoder import MAX_PIXELS, JPEGError, check_compiled, decode
from gfxlab.jpeg._tables import (
    AC_CHROMINANCE,
    AC_LUMINANCE,
    DC_CHROMINANCE,
    DC_LUMINANCE,
    SUBSAMPLING,
    ZIGZAG,
    ijg_tables,
)

__all__ = [
    "JPEGError",
    "MAX_PIXELS",
    "encode",
    "decode",
    "integer_tables",
    "coefficients",
]


# --- shared helpers --------------------------------------------------------------


def integer_tables(quality: int) -> tuple[np.ndarray, np.ndarray]:
    """libjpeg's `jpeg_set_quality(quality, force_baseline=TRUE)` tables (NumPy int32)."""
    return ijg_tables(min(max(int(quality), 1), 100), np)


def _check_quality(quality) -> int:
    if isinstance(quality, bool) or not isinstance(quality, int | np.integer):
        if isinstance(quality, float) and quality.is_integer():
            quality = int(quality)
        else:
            raise TypeError(f"`quality` must be an int in 1..100, got {quality!r}")
    if not 1 <= quality <= 100:
        raise ValueError(f"`quality` must be in 1..100, got {quality}")
    return int(quality)


_NAMES = {factors: name for name, factors in SUBSAMPLING.items()}


def _check_subsampling(subsampling) -> tuple[int, int]:
    if subsampling not in SUBSAMPLING:
        raise ValueError(f"`subsampling` must be one of {sorted(SUBSAMPLING)}, got {subsampling!r}")
    return SUBSAMPLING[subsampling]


def _as_uint8(image, *, batch: bool = False) -> np.ndarray:
    """`image` as uint8 `(H, W)` or `(H, W, 3)` (the JPEG-specific shape checks); with
    `batch`, a stack `(B, H, W, 3)` or `(B, H, W, 1)` -> `(B, H, W, 3)` / `(B, H, W)`."""
    if image is None:
        raise TypeError("`image` must be an image array, got None")
    if is_traced(image):
        raise TypeError(
            "`image` must be a concrete array: the file codec runs on the host and cannot "
            "be traced under jax.jit / vmap / grad (use `compress` for a differentiable round "
            "trip)"
        )
    arr = np.asarray(image)
    if arr.ndim == 0:  # a str, number or dict; dtypes are `to_uint8`'s to check
        raise TypeError(
            "`image` must be an image array: (H, W), (H, W, 1), (H, W, 3) or a stack "
            f"(B, H, W, 3) / (B, H, W, 1), got {type(image).__name__}"
        )
    if batch:
        if arr.ndim != 4 or arr.shape[-1] not in (1, 3):
            raise ValueError(
                f"`image` must be a stack (B, H, W, 3) or (B, H, W, 1), got shape {arr.shape}"
            )
        if arr.shape[0] < 1:
            raise ValueError(f"`image` is an empty stack (B = 0, shape {arr.shape}): no images")
        arr = arr[..., 0] if arr.shape[-1] == 1 else arr
        sides = arr.shape[1:3]
    else:
        if arr.ndim == 3 and arr.shape[-1] == 1:
            arr = arr[..., 0]
        if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[-1] != 3):
            raise ValueError(
                "`image` must have shape (H, W), (H, W, 1) or (H, W, 3), or be a stack "
                f"(B, H, W, 3) / (B, H, W, 1), got {arr.shape}"
            )
        sides = arr.shape[:2]
    if min(sides) < 1 or max(sides) > 65535:
        raise ValueError(f"`image` must be 1..65535 pixels on each side, got {arr.shape}")
    return to_uint8(arr, "image")


def coefficients(image, *, quality: int = 75, subsampling: str = "4:2:0") -> list[np.ndarray]:
    """The quantized DCT coefficients `encode` writes, per component.

    **Arguments:**

    - `image`: `(H, W, 3)` RGB or `(H, W)` grey, uint8 (or float in [0, 1]).
    - `quality`: IJG quality 1..100.
    - `subsampling`: `"4:4:4"`, `"4:2:2"` or `"4:2:0"`.

    **Returns:**

    One `(block_rows, block_cols, 8, 8)` int array per component (Y, Cb, Cr), natural
    order, the same layout as `jpeglib.read_dct(...).Y` etc.
    """
    arr = _as_uint8(image)
    quality = _check_quality(quality)
    factors = _check_subsampling(subsampling)
    planes, factors, tables, _ = _setup(arr, quality, factors)
    return L.forward(planes, factors, tables, np)


def _setup(arr, quality, luma_factors):
    luma, chroma = integer_tables(quality)
    if arr.ndim == 2:
        # Like Pillow, a grey file records the luma sampling factors of `subsampling`
        # (a lone component is coded block by block, so the data do not change).
        return [arr.astype(np.int64)], [luma_factors], [luma], [0]
    return (
        list(L.rgb_to_ycc(arr, np)),
        [luma_factors, (1, 1), (1, 1)],
        [luma, chroma, chroma],
        [
            0,
            1,
            1,
        ],
    )


# --- encoder ----------------------------------------------------------------------

# From this many pixels on, the dense core runs as compiled XLA programs (compiled
# once per image size, then several times faster than NumPy); smaller images stay in
# NumPy, where compiling would cost more than it saves.
_COMPILE_FROM_PIXELS = 1 << 16


@functools.lru_cache(maxsize=128)
def _divisors(quality: int, n_components: int) -> np.ndarray:
    luma, chroma = integer_tables(quality)
    return E.quantizers([luma, chroma, chroma][:n_components])


@functools.lru_cache(maxsize=128)
def _device_divisors(quality: int, n_components: int):
    import jax

    return jax.device_put(_divisors(quality, n_components))


def _aligned(arr: np.ndarray) -> np.ndarray:
    """`arr`, C-contiguous at a 64-byte boundary: JAX on CPU then uses the memory as it
    is instead of copying it (on a 512 x 512 RGB image the copy cost ~0.2 ms)."""
    if arr.flags.c_contiguous and arr.ctypes.data % 64 == 0:
        return arr
    buffer = np.empty(arr.nbytes + 64, np.uint8)
    start = -buffer.ctypes.data % 64
    out = buffer[start : start + arr.nbytes].view(arr.dtype).reshape(arr.shape)
    out[...] = arr
    return out


def _scan(arr: np.ndarray, quality: int, lay: E.Layout, *, compiled: bool | None = None) -> bytes:
    """Entropy-coded segment of `arr` (uint8, unpadded) for layout `lay`."""
    divisors = _divisors(quality, len(lay.components))
    padded = E.pad_input(arr, lay)
    if compiled is None:
        compiled = arr.shape[0] * arr.shape[1] >= _COMPILE_FROM_PIXELS
    if not compiled:
        return E.pack_scan(E.scan_events(padded, divisors, lay, np))
    # In bands, so that NumPy packs one band while XLA computes the next.
    padded, divisors = _aligned(padded), _device_divisors(quality, len(lay.components))
    factors = tuple(c.factors for c in lay.components) if lay.interleaved else ((1, 1),)
    plan = E.band_plan(arr.shape[0], arr.shape[1], factors)
    results = [E.compiled_band_events(band)(padded, divisors, row) for row, band in plan]
    return E.pack_bands(results, plan)


def _segment(marker: int, payload: bytes) -> bytes:
    return bytes([0xFF, marker]) + (len(payload) + 2).to_bytes(2, "big") + payload


def _dht(table_class: int, table_id: int, spec) -> bytes:
    bits, values = spec
    return _segment(0xC4, bytes([table_class << 4 | table_id, *bits, *values]))


def encode(
    image, *, quality: int = 75, subsampling: str = "4:2:0", compiled: bool | None = None
) -> bytes | list[bytes]:
    """Encode an image (or a stack of images) as baseline JFIF files, exactly as
    libjpeg-turbo does.

    The markers, tables, quantized coefficients and entropy-coded data are those of
    Pillow's `Image.save(buf, "JPEG", quality=quality, subsampling=...)` (Pillow's
    subsampling 0, 1, 2 = "4:4:4", "4:2:2", "4:2:0").

    Images of 65,536 pixels or more run as compiled XLA programs: the first call for
    an image size compiles them (about half a second on a laptop CPU), later calls of
    that size, at any quality, reuse them. Smaller images run in NumPy. `compiled`
    overrides that choice; the bytes are the same.

    A stack `(B, H, W, 3)` (RGB) or `(B, H, W, 1)` (grey) is encoded as a batch: one
    validation and conversion of the whole stack, one set of headers, and a pipeline
    in which the compiled programs of the next image run while NumPy packs the bits
    of the current one. Each file is the same as `encode` of that image alone.

    **Arguments:**

    - `image`: `(H, W, 3)` RGB or `(H, W)` / `(H, W, 1)` grey; uint8, or float in
      [0, 1] (clipped to [0, 1], then rounded to uint8, as `image.write_image` does;
      booleans become 0/255; other integers must lie in 0..255); or a stack of them.
    - `quality`: IJG quality, an int in 1..100.
    - `subsampling`: chroma subsampling `"4:4:4"`, `"4:2:2"` or `"4:2:0"`. For a grey
      image only the frame header's sampling factors change (as Pillow writes them).
    - `compiled`: `True` runs the compiled programs whatever the size (worth it for many
      small images of one size), `False` NumPy alone (no compilation: a one-off image in
      a short-lived process); `None` chooses by size. Under `jax.disable_jit()` NumPy
      always runs (compiled programs would run op by op, minutes per image).

    **Returns:**

    The file's bytes; for a stack, a list of `B` files.
    """
    batch = np.ndim(image) == 4 if image is not None and not is_traced(image) else False
    arr = _as_uint8(image, batch=batch)
    quality = _check_quality(quality)
    luma_factors = _check_subsampling(subsampling)
    compiled = check_compiled(compiled)
    if batch:
        return _encode_batch(arr, quality, luma_factors, compiled)
    height, width = arr.shape[:2]
    factors = (luma_factors,) if arr.ndim == 2 else (luma_factors, (1, 1), (1, 1))
    scan = _scan(arr, quality, E.layout(height, width, factors), compiled=compiled)
    return _headers(height, width, quality, factors) + scan + b"\xff\xd9"


def _encode_batch(arr: np.ndarray, quality: int, luma_factors, compiled) -> list[bytes]:
    """`encode` of each image of a uint8 stack `(B, H, W[, 3])`, pipelined: the compiled
    programs of image k + 1 are dispatched (XLA runs them asynchronously, on its own
    threads) before NumPy packs the bits of image k."""
    count, height, width = arr.shape[:3]
    factors = (luma_factors,) if arr.ndim == 3 else (luma_factors, (1, 1), (1, 1))
    lay = E.layout(height, width, factors)
    head = _headers(height, width, quality, factors)
    if not (height * width >= _COMPILE_FROM_PIXELS if compiled is None else compiled):
        # NumPy: nothing to overlap
        return [head + _scan(image, quality, lay, compiled=False) + b"\xff\xd9" for image in arr]
    plan = E.band_plan(height, width, tuple(c.factors for c in lay.components))
    programs = [(E.compiled_band_events(band), row) for row, band in plan]
    divisors = _device_divisors(quality, len(lay.components))

    def dispatch(k):
        padded = _aligned(E.pad_input(arr[k], lay))
        return [program(padded, divisors, row) for program, row in programs]

    files, pending = [], dispatch(0)
    for k in range(count):
        current, pending = pending, dispatch(k + 1) if k + 1 < count else None
        files.append(head + E.pack_bands(current, plan) + b"\xff\xd9")
    return files


@functools.lru_cache(maxsize=256)
def _headers(height: int, width: int, quality: int, factors: tuple) -> bytes:
    """SOI, JFIF APP0, DQT, SOF0, DHT and SOS segments, as libjpeg writes them."""
    n_comp = len(factors)
    n_tables = 1 if n_comp == 1 else 2
    tables = integer_tables(quality)[:n_tables]
    table_ids = [0] if n_comp == 1 else [0, 1, 1]
    out = [b"\xff\xd8", _segment(0xE0, b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00")]
    for t in range(n_tables):
        zz = tables[t].reshape(-1)[ZIGZAG]
        out.append(_segment(0xDB, bytes([t, *zz.astype(np.uint8).tolist()])))
    sof = bytes([8, *height.to_bytes(2, "big"), *width.to_bytes(2, "big"), n_comp])
    for c, ((h, v), t) in enumerate(zip(factors, table_ids, strict=True)):
        sof += bytes([c + 1, h << 4 | v, t])
    out.append(_segment(0xC0, sof))
    specs = [(DC_LUMINANCE, AC_LUMINANCE), (DC_CHROMINANCE, AC_CHROMINANCE)]
    for t in range(n_tables):
        out += [_dht(0, t, specs[t][0]), _dht(1, t, specs[t][1])]
    sos = bytes([n_comp])
    for c, t in enumerate(table_ids):
        sos += bytes([c + 1, t << 4 | t])
    out.append(_segment(0xDA, sos + b"\x00\x3f\x00"))
    return b"".join(out)
