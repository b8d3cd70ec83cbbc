"""`decode`: baseline JPEG files, pixel for pixel as libjpeg-turbo decodes them.

The markers are parsed in Python; the scan is entropy-decoded by `_entropy` (by the
compiled loop of `_entropy_xla` for large images) straight into a planar coefficient
array: per component, each of the 64 coefficient positions is one contiguous row over
all its blocks, the layout in which XLA runs the IDCT fastest (the coefficients stay
on the device). The pixels are then reconstructed exactly as
libjpeg-turbo does by default (islow IDCT, fancy upsampling, its colour tables),
vectorized over all blocks: NumPy for small images; for large ones one compiled
program per image geometry.

The colour space follows libjpeg's rules (`jdapimin.c`): one component is grey;
three are YCbCr when a JFIF marker is present, else as an Adobe APP14 marker's
transform says (0: RGB, no conversion), else RGB when the component ids are 'R', 'G',
'B', else YCbCr.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from gfxlab._plain_args import flag
from gfxlab._xla_options import legacy_cpu_emitters
from gfxlab.jpeg import _libjpeg as L
from gfxlab.jpeg._entropy import HuffmanTable, JPEGError, decode_scan
from gfxlab.jpeg._tables import ZIGZAG

__all__ = ["JPEGError", "MAX_PIXELS", "decode"]

#: Default pixel limit of `decode` (Pillow's `Image.MAX_IMAGE_PIXELS`): a file whose
#: frame declares more pixels is refused before anything is allocated.
MAX_PIXELS = 89_478_485

_UNSUPPORTED_SOF = {
    0xC2: "progressive JPEG",
    0xC3: "lossless JPEG",
    0xC5: "hierarchical (differential sequential) JPEG",
    0xC6: "hierarchical (differential progressive) JPEG",
    0xC7: "hierarchical (differential lossless) JPEG",
    0xC9: "arithmetic-coded JPEG",
    0xCA: "arithmetic-coded progressive JPEG",
    0xCB: "arithmetic-coded lossless JPEG",
    0xCD: "arithmetic-coded hierarchical JPEG",
    0xCE: "arithmetic-coded hierarchical JPEG",
    0xCF: "arithmetic-coded hierarchical JPEG",
    0xCC: "arithmetic coding (DAC marker)",
}
# From this many pixels on, the reconstruction runs as a compiled XLA program.
_COMPILE_FROM_PIXELS = 1 << 16


def _parse_sof(seg: bytes, max_pixels):
    if len(seg) < 6:
        raise JPEGError("truncated SOF segment")
    precision, height, width, n = seg[0], int.from_bytes(seg[1:3]), int.from_bytes(seg[3:5]), seg[5]
    if precision != 8:
        raise JPEGError(f"unsupported sample precision {precision} bits (only 8-bit baseline)")
    if height == 0:
        raise JPEGError("unsupported: image height 0 (DNL marker)")
    if width == 0:
        raise JPEGError("corrupt SOF: image width 0")
    if max_pixels is not None and height * width > max_pixels:
        raise JPEGError(
            f"image of {width} x {height} = {width * height} pixels exceeds the limit "
            f"`max_pixels` = {max_pixels} (a decompression-bomb guard; raise it to decode)"
        )
    if n == 4:
        raise JPEGError("unsupported: 4-component (CMYK or YCCK) JPEG; only grey and 3-colour")
    if n not in (1, 3):
        raise JPEGError(f"unsupported number of components {n} (only grey or 3-colour)")
    if len(seg) != 6 + 3 * n:
        raise JPEGError("corrupt SOF segment length")
    comps = []
    for i in range(n):
        cid, hv, tq = seg[6 + 3 * i : 9 + 3 * i]
        h, v = hv >> 4, hv & 15
        if not (1 <= h <= 4 and 1 <= v <= 4) or tq > 3:
            raise JPEGError(f"corrupt SOF: component {cid} sampling {h}x{v}, table {tq}")
        comps.append((cid, h, v, tq))
    if len({c[0] for c in comps}) != n:
        raise JPEGError("corrupt SOF: duplicate component ids")
    hmax = max(c[1] for c in comps)
    vmax = max(c[2] for c in comps)
    if any(hmax % c[1] or vmax % c[2] for c in comps):
        raise JPEGError("unsupported: fractional sampling factors")
    return height, width, comps


def _parse_dqt(seg: bytes, tables: dict):
    i = 0
    while i < len(seg):
        precision, tid = seg[i] >> 4, seg[i] & 15
        size = 64 * (precision + 1)
        if precision > 1 or tid > 3 or i + 1 + size > len(seg):
            raise JPEGError("corrupt DQT segment")
        raw = np.frombuffer(seg[i + 1 : i + 1 + size], ">u2" if precision else np.uint8)
        table = np.zeros(64, np.int64)
        table[ZIGZAG] = raw
        if np.any(table == 0):
            raise JPEGError("corrupt DQT segment: zero quantizer")
        tables[tid] = table.reshape(8, 8)
        i += 1 + size


def _parse_dht(seg: bytes, tables: dict):
    i = 0
    while i < len(seg):
        if i + 17 > len(seg):
            raise JPEGError("truncated DHT segment")
        tc, th = seg[i] >> 4, seg[i] & 15
        bits = tuple(seg[i + 1 : i + 17])
        count = sum(bits)
        if tc > 1 or th > 3 or count > 256 or i + 17 + count > len(seg):
            raise JPEGError("corrupt DHT segment (bad Huffman table header)")
        values = tuple(seg[i + 17 : i + 17 + count])
        tables[tc, th] = _huffman_table(bits, values, tc)
        i += 17 + count


@functools.lru_cache(maxsize=64)
def _huffman_table(bits: tuple, values: tuple, table_class: int) -> HuffmanTable:
    """Decode tables, cached: most files use the same few (Annex K or Pillow's)."""
    return HuffmanTable((bits, values), table_class)


def _scan_end(d: bytes, start: int) -> int:
    """Index of the first marker (not RSTn, not a stuffed 0xFF00) after `start`, or
    the end of the file."""
    arr = np.frombuffer(d, np.uint8, offset=start)
    ff = np.flatnonzero(arr[:-1] == 0xFF)
    nxt = arr[ff + 1]
    real = ff[(nxt != 0) & ((nxt < 0xD0) | (nxt > 0xD7))]
    return start + int(real[0]) if real.size else len(d)


def _cdiv(a: int, b: int) -> int:
    return -(-a // b)


class _State:
    """What the markers before the scan said."""

    def __init__(self, max_pixels, compiled: bool | None = None):
        self.max_pixels, self.compiled = max_pixels, compiled
        self.quant: dict = {}
        self.huff: dict = {}
        self.frame = None
        self.restart = 0
        self.jfif = False
        self.adobe = None  # the Adobe APP14 transform, if seen

    def segment(self, marker: int, seg: bytes) -> None:
        if marker in _UNSUPPORTED_SOF:
            raise JPEGError(f"unsupported: {_UNSUPPORTED_SOF[marker]} (only baseline is decoded)")
        if marker in (0xC0, 0xC1):
            if self.frame is not None:
                raise JPEGError("corrupt JPEG: more than one frame header")
            self.frame = _parse_sof(seg, self.max_pixels)
        elif marker == 0xC4:
            _parse_dht(seg, self.huff)
        elif marker == 0xDB:
            _parse_dqt(seg, self.quant)
        elif marker == 0xDD:
            if len(seg) != 2:
                raise JPEGError("corrupt DRI segment")
            self.restart = int.from_bytes(seg)
        elif marker == 0xE0 and seg[:5] == b"JFIF\x00":
            self.jfif = True
        elif marker == 0xEE and seg[:5] == b"Adobe" and len(seg) >= 12:
            self.adobe = seg[11]

    def colour(self) -> str:
        """libjpeg-turbo's `default_decompress_parms` for 1 or 3 components."""
        comps = self.frame[2]
        if len(comps) == 1:
            return "grey"
        if self.jfif:
            return "ycc"
        if self.adobe is not None:
            return "rgb" if self.adobe == 0 else "ycc"
        return "rgb" if tuple(c[0] for c in comps) == (82, 71, 66) else "ycc"


def _decode(d: bytes, max_pixels, compiled=None) -> np.ndarray:  # noqa: C901 - one per marker
    n = len(d)
    if n < 4 or d[0] != 0xFF or d[1] != 0xD8:
        raise JPEGError("not a JPEG file: missing SOI marker")
    state = _State(max_pixels, compiled)
    image = None
    pos = 2
    while True:  # every pass consumes at least one byte, so this ends
        if pos >= n:
            if image is None:
                raise JPEGError("truncated JPEG: no EOI marker")
            warnings.warn("JPEG file has no EOI marker after its scan", stacklevel=3)
            return image
        if d[pos] != 0xFF:
            raise JPEGError(f"corrupt JPEG: expected a marker at byte {pos}")
        while pos < n and d[pos] == 0xFF:
            pos += 1
        if pos >= n:
            raise JPEGError("truncated JPEG: file ends inside a marker")
        marker = d[pos]
        pos += 1
        if marker == 0xD9:
            if image is None:
                raise JPEGError("corrupt JPEG: EOI before any image data")
            return image
        if marker == 0x01:
            continue
        if marker == 0xD8 or 0xD0 <= marker <= 0xD7 or marker == 0x00:
            raise JPEGError(f"corrupt JPEG: unexpected marker 0xFF{marker:02X} at byte {pos - 2}")
        if pos + 2 > n:
            raise JPEGError("truncated JPEG: file ends inside a marker segment")
        length = int.from_bytes(d[pos : pos + 2])
        if length < 2 or pos + length > n:
            raise JPEGError(f"truncated or corrupt JPEG: marker 0xFF{marker:02X} segment length")
        seg = d[pos + 2 : pos + length]
        pos += length
        if marker != 0xDA:
            state.segment(marker, seg)
            continue
        if state.frame is None:
            raise JPEGError("corrupt JPEG: scan before frame header")
        if image is not None:
            raise JPEGError("unsupported: more than one scan (only single-scan baseline)")
        end = _scan_end(d, pos)
        image = _decode_image(state, seg, d[pos:end])
        pos = end


def _scan_plan(state: _State, sos: bytes):
    """Component order and per-block Huffman plan of the scan header `sos`."""
    comps = state.frame[2]
    if len(sos) < 1 or len(sos) != 4 + 2 * sos[0]:
        raise JPEGError("corrupt SOS segment")
    ns = sos[0]
    if ns != len(comps):
        raise JPEGError("unsupported: scan does not contain every component (multi-scan)")
    ss, se, ahal = sos[1 + 2 * ns :]
    if (ss, se, ahal) != (0, 63, 0):
        raise JPEGError("unsupported: spectral selection / successive approximation")
    ids = [c[0] for c in comps]
    order, plan = [], []
    for j in range(ns):
        cid, tables = sos[1 + 2 * j], sos[2 + 2 * j]
        if cid not in ids or ids.index(cid) in order:
            raise JPEGError(f"corrupt SOS: unknown or repeated component {cid}")
        i = ids.index(cid)
        td, ta = tables >> 4, tables & 15
        if (0, td) not in state.huff or (1, ta) not in state.huff:
            raise JPEGError(f"corrupt JPEG: missing Huffman table for component {cid}")
        if comps[i][3] not in state.quant:
            raise JPEGError(f"corrupt JPEG: missing quantization table for component {cid}")
        order.append(i)
        blocks = 1 if ns == 1 else comps[i][1] * comps[i][2]
        plan += [(j, state.huff[0, td], state.huff[1, ta])] * blocks
    if ns > 1 and len(plan) > 10:
        raise JPEGError("corrupt SOF: more than 10 blocks per MCU")
    return order, plan


def _decode_image(state: _State, sos: bytes, data: bytes) -> np.ndarray:
    height, width, comps = state.frame
    order, plan = _scan_plan(state, sos)
    factors = tuple((c[1], c[2]) for c in comps)
    # Every block takes at least two bits: a frame that cannot fit in the scan is
    # refused before its block plan and coefficients are allocated.
    if 2 * _block_count(height, width, factors, order) > 8 * len(data):
        raise JPEGError(
            f"truncated JPEG: a {width} x {height} frame cannot fit in {len(data)} bytes of "
            "scan data"
        )
    dest, places = _destinations(height, width, factors, tuple(order))
    n_mcu = dest.size // len(plan)
    coef, stride = decode_scan(data, plan, n_mcu, state.restart, dest, compiled=state.compiled)
    tables = np.stack([state.quant[c[3]] for c in comps]).astype(np.int32)
    geometry = (height, width, factors, places, state.colour())
    compiled = state.compiled
    if height * width >= _COMPILE_FROM_PIXELS if compiled is None else compiled:
        return _reconstruct_compiled(coef, stride, tables, geometry)
    return _reconstruct(np.asarray(coef), stride, tables, geometry)


def _block_grid(height: int, width: int, h: int, v: int, hmax: int, vmax: int):
    """A component's real blocks `(rows, cols)` (libjpeg's `jdiv_round_up` rules)."""
    return _cdiv(_cdiv(height * v, vmax), 8), _cdiv(_cdiv(width * h, hmax), 8)


def _block_count(height: int, width: int, factors: tuple, order: list) -> int:
    """The blocks a scan of components `order` codes (MCU padding included)."""
    hmax = max(f[0] for f in factors)
    vmax = max(f[1] for f in factors)
    if len(order) == 1:
        rows, cols = _block_grid(height, width, *factors[order[0]], hmax, vmax)
        return rows * cols
    per_mcu = sum(factors[i][0] * factors[i][1] for i in order)
    return _cdiv(width, 8 * hmax) * _cdiv(height, 8 * vmax) * per_mcu


@functools.lru_cache(maxsize=64)
def _destinations(height: int, width: int, factors: tuple, order: tuple):
    """Where the scan's blocks go: `dest[b]` for the block at scan position `b` (a
    planar index: the components one after the other, each block row-major over the
    component's block grid, MCU padding included) and, per frame component,
    `(first index, grid rows, grid cols, rows, cols)` of its real blocks (a scan of
    one component: a frame of one component)."""
    hmax = max(f[0] for f in factors)
    vmax = max(f[1] for f in factors)
    places, pieces, first = {}, [], 0  # by frame component
    if len(order) == 1:
        h, v = factors[order[0]]
        rows, cols = _block_grid(height, width, h, v, hmax, vmax)
        return np.arange(rows * cols, dtype=np.int32), ((0, rows, cols, rows, cols),)
    mcu_x, mcu_y = _cdiv(width, 8 * hmax), _cdiv(height, 8 * vmax)
    mcu_row, mcu_col = np.divmod(np.arange(mcu_x * mcu_y), mcu_x)
    for i in order:
        h, v = factors[i]
        rows, cols = _block_grid(height, width, h, v, hmax, vmax)
        places[i] = (first, mcu_y * v, mcu_x * h, rows, cols)
        dv, dh = np.divmod(np.arange(v * h), h)  # block order within the MCU
        grid_row = mcu_row[:, None] * v + dv
        grid_col = mcu_col[:, None] * h + dh
        pieces.append(first + grid_row * (mcu_x * h) + grid_col)
        first += mcu_x * mcu_y * v * h
    dest = np.concatenate(pieces, axis=1).reshape(-1).astype(np.int32)
    return dest, tuple(places[i] for i in range(len(factors)))


def _component_blocks(coef, stride: int, place, xp):
    """One component's real blocks `(8, 8, rows, cols)` (natural order) from the flat
    coefficients `decode_scan` returns."""
    first, grid_rows, grid_cols, rows, cols = place
    planar = coef[: 64 * stride].reshape(64, stride)[:, first : first + grid_rows * grid_cols]
    return planar.reshape(8, 8, grid_rows, grid_cols)[:, :, :rows, :cols]


def _reconstruct(coef, stride, tables, geometry):
    """Coefficients -> uint8 pixels in NumPy: dequantize, islow IDCT, upsample, colour."""
    height, width, factors, places, colour = geometry
    n = len(factors)
    blocks = [
        _component_blocks(coef, stride, places[i], np).astype(np.int64).transpose(2, 3, 0, 1)
        for i in range(n)
    ]
    planes = L.inverse(blocks, list(factors), [tables[i] for i in range(n)], height, width, np)
    return _colour(planes, colour, np)


def _colour(planes, colour: str, xp):
    if colour == "grey":
        return planes[0].astype(np.uint8)
    if colour == "rgb":
        return xp.stack(planes, axis=-1).astype(np.uint8)
    return L.ycc_to_rgb(*planes, xp)


def _reconstruct_compiled(coef, stride, tables, geometry):
    """`_reconstruct` as one compiled program per image geometry."""
    return np.asarray(_compiled_reconstruct(geometry, stride)(coef, tables))


def _image_order(block_samples, xp):
    """`(8, 8, rows, cols)` samples (0..255) -> the `(8 rows, 8 cols)` uint8 plane.

    XLA transposes this layout slowly (byte by byte, several times the IDCT's cost);
    instead each run of 4 horizontal samples is packed into a uint32 word in the
    planar layout (elementwise), the words are moved into image order and the bytes
    read back in place (little-endian, as XLA's CPU and GPU targets are)."""
    from jax import lax

    s = block_samples.astype(xp.uint32)
    words = [s[:, x] | s[:, x + 1] << 8 | s[:, x + 2] << 16 | s[:, x + 3] << 24 for x in (0, 4)]
    words = xp.stack(words, axis=-1).transpose(1, 0, 2, 3)  # (rows, 8, cols, 2)
    rows, _, cols, _ = words.shape
    return lax.bitcast_convert_type(words, xp.uint8).reshape(8 * rows, 8 * cols)


@functools.lru_cache(maxsize=32)
def _compiled_reconstruct(geometry, stride: int):
    import jax
    import jax.numpy as jnp

    height, width, factors, places, colour = geometry
    _, _, layout = L.component_layout(height, width, factors)

    def reconstruct(coef, tables):
        samples = []
        for i, (place, (_, (h_c, w_c), _)) in enumerate(zip(places, layout, strict=True)):
            blocks = _component_blocks(coef, stride, place, jnp).astype(jnp.int32)
            samples.append(
                _image_order(L.idct_islow_planar(blocks, tables[i], jnp), jnp)[:h_c, :w_c]
            )
        planes = L.upsample_planes(samples, factors, height, width, jnp)
        return _colour(planes, colour, jnp)

    return jax.jit(reconstruct, compiler_options=legacy_cpu_emitters())


def check_compiled(compiled) -> bool | None:
    """The `compiled` option of `encode` and `decode`: True, False or None; False under
    `jax.disable_jit()`, where the compiled programs would run op by op (minutes for one
    image, measured) and NumPy gives the same bytes and pixels."""
    compiled = flag(compiled, "compiled", optional=True)
    import jax

    return False if jax.config.jax_disable_jit else compiled


def _file_bytes(data) -> bytes | bytearray | memoryview:
    """`decode`'s `data` as a bytes-like object; a 1-D uint8 NumPy or JAX array (e.g.
    `np.fromfile(path, np.uint8)`) gives its bytes."""
    import jax

    if isinstance(data, bytes | bytearray | memoryview):  # np.bytes_ too
        return data
    if isinstance(data, jax.core.Tracer):
        raise TypeError(
            "`data` must be a concrete byte string: the file decoder runs on the host and "
            "cannot be traced under jax.jit / vmap / grad (decode outside, then trace the pixels)"
        )
    if isinstance(data, np.ndarray | np.generic | jax.Array):
        if data.dtype != np.uint8 or data.ndim != 1:
            raise TypeError(
                "`data` as an array must be 1-D uint8 (the file's bytes), got "
                f"{data.ndim}-D {data.dtype}"
            )
        return np.asarray(data).tobytes()
    raise TypeError(
        "`data` must be bytes, bytearray, memoryview or a 1-D uint8 array, got "
        f"{type(data).__name__}"
    )


def decode(
    data, *, max_pixels: int | None = MAX_PIXELS, compiled: bool | None = None
) -> np.ndarray:
    """Decode a baseline JPEG file exactly as libjpeg-turbo does by default (islow
    IDCT, fancy upsampling), e.g. as Pillow's `Image.open(...)`.

    Memory stays proportional to the image (its coefficients and pixels, about 3x the
    decoded size) plus a few times the file size; the number of pixels is bounded by
    `max_pixels` before anything is allocated (Pillow's decompression-bomb limit).
    Colour follows libjpeg: JFIF files are YCbCr; Adobe-marked (transform 0) or
    'R', 'G', 'B'-labelled files are RGB and are not colour-converted. A file that
    ends after a complete scan without its EOI marker decodes with a warning.

    Images of 1024 blocks or more (64 K pixels) are entropy-decoded by a compiled XLA
    loop and reconstructed by one compiled program: the first file of a size bucket
    compiles them (seconds), later files of similar size reuse them. Smaller images are
    decoded in Python and NumPy. `compiled` overrides that choice; the pixels are the same.

    **Arguments:**

    - `data`: the file's bytes (`bytes`, `bytearray`, `memoryview` or a 1-D uint8 NumPy
      or JAX array).
    - `max_pixels`: refuse frames of more pixels than this (`None`: no limit).
    - `compiled`: `True` decodes with the compiled programs whatever the size (worth it
      for many small files of one size), `False` without them (no compilation: a
      one-off file in a short-lived process); `None` chooses by size. Under
      `jax.disable_jit()` NumPy always runs (compiled programs would run op by op).

    **Returns:**

    `(H, W, 3)` uint8 RGB, or `(H, W)` uint8 for a greyscale file.

    Raises `JPEGError` (a `ValueError`) for anything that is not a well-formed
    baseline (or extended sequential Huffman, 8-bit) JPEG with one scan and 1 or 3
    components: garbage, truncated files, bad tables, progressive, arithmetic-coded,
    lossless, 12-bit, CMYK/YCCK files, or frames over `max_pixels`. Every loop is
    bounded by the input length.
    """
    data = _file_bytes(data)
    if max_pixels is not None:
        if isinstance(max_pixels, bool) or not isinstance(max_pixels, int | np.integer):
            raise TypeError(f"`max_pixels` must be an int or None, got {max_pixels!r}")
        if max_pixels < 1:
            raise ValueError(f"`max_pixels` must be >= 1, got {max_pixels}")
    compiled = check_compiled(compiled)
    d = bytes(data)
    try:
        return _decode(d, max_pixels, compiled)
    except JPEGError:
        raise
    except (IndexError, ValueError, OverflowError, KeyError) as err:  # defensive net
        raise JPEGError(f"corrupt JPEG: {err}") from None
