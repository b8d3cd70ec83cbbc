"""Baseline JFIF files: `encode` (bit-exact with libjpeg-turbo / Pillow) and `decode`.

The encoder (`_encoder`) runs libjpeg's integer pipeline on all blocks at once and
turns every coefficient slot into at most one Huffman event (a DC difference, a ZRL,
a run/size code with its extra bits, an EOB), all static shapes: NumPy for small
images, compiled XLA programs for large ones. NumPy then drops the empty slots,
concatenates the bits into 32-bit words and 0xFF-stuffs the bytes.

The decoder parses the markers, then decodes the entropy-coded data with one Python
step per Huffman symbol over precomputed tables (a 16-bit look-ahead window at every
bit position), and reconstructs pixels exactly as libjpeg-turbo does by default
(islow IDCT, fancy upsampling), again vectorized over blocks.
"""

from __future__ import annotations

import functools

import numpy as np

from gfxlab.jpeg import _encoder as E
from gfxlab.jpeg import _libjpeg as L
from gfxlab.jpeg._tables import (
    AC_CHROMINANCE,
    AC_LUMINANCE,
    DC_CHROMINANCE,
    DC_LUMINANCE,
    SUBSAMPLING,
    ZIGZAG,
    huffman_codes,
)

__all__ = ["JPEGError", "encode", "decode", "integer_tables", "coefficients"]


class JPEGError(ValueError):
    """A JPEG stream is corrupt, truncated or uses a feature we do not decode."""


# --- shared helpers --------------------------------------------------------------


def integer_tables(quality: int) -> tuple[np.ndarray, np.ndarray]:
    """libjpeg's `jpeg_set_quality(quality, force_baseline=TRUE)` tables (NumPy int32)."""
    from gfxlab.jpeg._tables import CHROMINANCE_TABLE, LUMINANCE_TABLE

    quality = min(max(int(quality), 1), 100)
    scale = 5000 // quality if quality < 50 else 200 - 2 * quality
    return tuple(
        np.clip((base.astype(np.int64) * scale + 50) // 100, 1, 255).astype(np.int32)
        for base in (LUMINANCE_TABLE, CHROMINANCE_TABLE)
    )


def _check_quality(quality) -> int:
    if isinstance(quality, bool) or not isinstance(quality, int | np.integer):
        if isinstance(quality, float) and quality.is_integer():
            quality = int(quality)
        else:
            raise TypeError(f"`quality` must be an int in 1..100, got {quality!r}")
    if not 1 <= quality <= 100:
        raise ValueError(f"`quality` must be in 1..100, got {quality}")
    return int(quality)


def _check_subsampling(subsampling) -> tuple[int, int]:
    if subsampling not in SUBSAMPLING:
        raise ValueError(f"`subsampling` must be one of {sorted(SUBSAMPLING)}, got {subsampling!r}")
    return SUBSAMPLING[subsampling]


def _as_uint8(image) -> np.ndarray:
    arr = np.asarray(image)
    if arr.ndim == 3 and arr.shape[-1] == 1:
        arr = arr[..., 0]
    if arr.ndim not in (2, 3) or (arr.ndim == 3 and arr.shape[-1] != 3):
        raise ValueError(f"`image` must have shape (H, W), (H, W, 1) or (H, W, 3), got {arr.shape}")
    if arr.shape[0] < 1 or arr.shape[1] < 1 or max(arr.shape[:2]) > 65535:
        raise ValueError(f"`image` must be 1..65535 pixels on each side, got {arr.shape}")
    if arr.dtype == np.uint8:
        return arr
    if np.issubdtype(arr.dtype, np.floating):
        if not np.all(np.isfinite(arr)):
            raise ValueError("`image` must be finite")
        return np.clip(np.round(arr * 255.0), 0, 255).astype(np.uint8)
    if np.issubdtype(arr.dtype, np.integer) or arr.dtype == bool:
        if arr.dtype != bool and (arr.min() < 0 or arr.max() > 255):
            raise ValueError("integer `image` values must lie in 0..255")
        return arr.astype(np.uint8) * (255 if arr.dtype == bool else 1)
    raise TypeError(f"`image` must be uint8 or float in [0, 1], got dtype {arr.dtype}")


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


def encode(image, *, quality: int = 75, subsampling: str = "4:2:0") -> bytes:
    """Encode an image as a baseline JFIF file, exactly as libjpeg-turbo does.

    The markers, tables, quantized coefficients and entropy-coded data are those of
    Pillow's `Image.save(buf, "JPEG", quality=quality, subsampling=...)` (Pillow's
    subsampling 0, 1, 2 = "4:4:4", "4:2:2", "4:2:0").

    Images of 65,536 pixels or more run as compiled XLA programs: the first call for
    an image size compiles them (about half a second on a laptop CPU), later calls of
    that size, at any quality, reuse them. Smaller images run in NumPy.

    **Arguments:**

    - `image`: `(H, W, 3)` RGB or `(H, W)` / `(H, W, 1)` grey; uint8, or float in
      [0, 1] (rounded to uint8 first).
    - `quality`: IJG quality, an int in 1..100.
    - `subsampling`: chroma subsampling `"4:4:4"`, `"4:2:2"` or `"4:2:0"`. For a grey
      image only the frame header's sampling factors change (as Pillow writes them).

    **Returns:**

    The file's bytes.
    """
    arr = _as_uint8(image)
    quality = _check_quality(quality)
    luma_factors = _check_subsampling(subsampling)
    height, width = arr.shape[:2]
    factors = (luma_factors,) if arr.ndim == 2 else (luma_factors, (1, 1), (1, 1))
    scan = _scan(arr, quality, E.layout(height, width, factors))
    return _headers(height, width, quality, factors) + scan + b"\xff\xd9"


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


# --- decoder ----------------------------------------------------------------------

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
_PAD_BYTES = 264  # look-ahead slack: one block reads at most 64 * 32 bits


def _lookup(spec, table_class: int):
    """Huffman decode table over all 16-bit windows: `(length << 8) | symbol`, 0 where
    no code matches."""
    try:
        codes = huffman_codes(spec)
    except ValueError as err:
        raise JPEGError(f"bad Huffman table: {err}") from None
    lut = np.zeros(1 << 16, np.int64)
    limit = 11 if table_class == 0 else 255
    for symbol, (code, length) in codes.items():
        if (table_class == 0 and symbol > limit) or (table_class == 1 and symbol & 15 > 10):
            continue  # never valid in a baseline stream; decoding it is an error
        lo = code << (16 - length)
        lut[lo : lo + (1 << (16 - length))] = (length << 8) | symbol
    return lut


def _parse_sof(seg: bytes, marker: int):
    if len(seg) < 6:
        raise JPEGError("truncated SOF segment")
    precision, height, width, n = seg[0], int.from_bytes(seg[1:3]), int.from_bytes(seg[3:5]), seg[5]
    if precision != 8:
        raise JPEGError(f"unsupported sample precision {precision} bits (only 8-bit baseline)")
    if height == 0:
        raise JPEGError("unsupported: image height 0 (DNL marker)")
    if width == 0:
        raise JPEGError("corrupt SOF: image width 0")
    if n not in (1, 3):
        raise JPEGError(f"unsupported number of components {n} (only grey or YCbCr)")
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
        tables[tc, th] = _lookup((bits, values), tc)
        i += 17 + count


def _scan_end(d: bytes, start: int) -> int:
    """Index of the first marker (not RSTn, not a stuffed 0xFF00) after `start`."""
    arr = np.frombuffer(d, np.uint8, offset=start)
    ff = np.flatnonzero(arr[:-1] == 0xFF)
    nxt = arr[ff + 1]
    real = ff[(nxt != 0) & ((nxt < 0xD0) | (nxt > 0xD7))]
    if real.size == 0:
        raise JPEGError("truncated JPEG: entropy-coded data runs to the end of the file")
    return start + int(real[0])


def _entropy_segments(data: bytes):
    """Split at RST markers and remove stuffing: (bytes, bit offsets of segments)."""
    arr = np.frombuffer(data, np.uint8)
    is_ff = arr == 0xFF
    nxt = np.concatenate([arr[1:], [0]])
    rst = np.flatnonzero(is_ff & (nxt >= 0xD0) & (nxt <= 0xD7))
    bounds = np.concatenate([[0], rst, [arr.size]])
    pieces, starts, pos = [], [], 0
    for k in range(bounds.size - 1):
        lo = bounds[k] + (2 if k else 0)
        seg = arr[lo : bounds[k + 1]]
        prev_ff = np.concatenate([[False], seg[:-1] == 0xFF])
        seg = seg[~(prev_ff & (seg == 0))]
        pieces.append(seg)
        starts.append(pos)
        pos += 8 * seg.size
    starts.append(pos)
    return np.concatenate(pieces) if pieces else np.zeros(0, np.uint8), starts


def _decode_scan(data: bytes, schedule, n_mcu: int, restart: int, huff: dict):
    """Entropy-decode one interleaved (or single-component) baseline scan.

    `schedule`: per block of an MCU, `(component, dc_table, ac_table)`. Returns the
    DC values and the (flat index, value) of every nonzero AC coefficient, per block
    in scan order with 64 zig-zag slots per block.
    """
    stream, starts = _entropy_segments(data)
    n_bits = starts[-1]
    n_blocks = n_mcu * len(schedule)
    if 2 * n_blocks > n_bits:
        raise JPEGError(
            f"truncated JPEG: {n_blocks} blocks cannot fit in {n_bits} bits of scan data"
        )
    padded = np.concatenate([stream, np.zeros(_PAD_BYTES, np.uint8)]).astype(np.int64)
    triple = (padded[:-2] << 16) | (padded[1:-1] << 8) | padded[2:]
    positions = np.arange(8 * (padded.size - 2))
    window = (triple[positions >> 3] >> (8 - (positions & 7))) & 0xFFFF
    lists = {key: lut[window].tolist() for key, lut in huff.items()}
    W = window.tolist()
    plan = [(c, lists[0, td], lists[1, ta]) for c, td, ta in schedule]

    dcs = [0] * n_blocks
    ac_index: list[int] = []
    ac_value: list[int] = []
    pred = [0] * 4
    p = 0
    segment = 0
    seg_end = starts[1]
    b = 0
    for mcu in range(n_mcu):
        if restart and mcu and mcu % restart == 0:
            segment += 1
            if segment >= len(starts) - 1:
                raise JPEGError("truncated JPEG: missing restart interval")
            p, seg_end = starts[segment], starts[segment + 1]
            pred = [0] * 4
        for c, dc_lut, ac_lut in plan:
            e = dc_lut[p]
            if not e:
                raise JPEGError(f"corrupt JPEG: invalid DC Huffman code at bit {p}")
            p += e >> 8
            s = e & 255
            if s:
                v = W[p] >> (16 - s)
                if v < (1 << (s - 1)):
                    v -= (1 << s) - 1
                p += s
                pred[c] += v
            dcs[b] = pred[c]
            base = 64 * b
            k = 1
            while k < 64:
                e = ac_lut[p]
                if not e:
                    raise JPEGError(f"corrupt JPEG: invalid AC Huffman code at bit {p}")
                p += e >> 8
                rs = e & 255
                s = rs & 15
                if s:
                    k += rs >> 4
                    if k > 63:
                        raise JPEGError("corrupt JPEG: AC run past the end of a block")
                    v = W[p] >> (16 - s)
                    if v < (1 << (s - 1)):
                        v -= (1 << s) - 1
                    p += s
                    ac_index.append(base + k)
                    ac_value.append(v)
                    k += 1
                elif rs == 0xF0:
                    k += 16
                else:
                    break
            b += 1
            if p > seg_end:
                raise JPEGError("truncated or corrupt JPEG: scan data ended inside a block")
    return np.asarray(dcs, np.int64), np.asarray(ac_index, np.int64), np.asarray(ac_value, np.int64)


def _cdiv(a: int, b: int) -> int:
    return -(-a // b)


def _blocks_per_component(coef, comps, order, height, width):
    """Scan-order blocks `(N, 64)` (zig-zag) -> per frame component, natural order,
    `(rows, cols, 8, 8)` real blocks."""
    natural = np.empty_like(coef)
    natural[:, ZIGZAG] = coef
    hmax = max(c[1] for c in comps)
    vmax = max(c[2] for c in comps)
    out = {}
    if len(order) == 1:
        cid, h, v, _ = comps[order[0]]
        rows = _cdiv(_cdiv(height * v, vmax), 8)
        cols = _cdiv(_cdiv(width * h, hmax), 8)
        out[order[0]] = natural.reshape(rows, cols, 8, 8)
        return out
    mcu_x = -(-width // (8 * hmax))
    mcu_y = -(-height // (8 * vmax))
    per_mcu = natural.reshape(mcu_y * mcu_x, -1, 64)
    first = 0
    for i in order:
        _, h, v, _ = comps[i]
        part = per_mcu[:, first : first + h * v].reshape(mcu_y, mcu_x, v, h, 8, 8)
        first += h * v
        grid = part.transpose(0, 2, 1, 3, 4, 5).reshape(mcu_y * v, mcu_x * h, 8, 8)
        rows = _cdiv(_cdiv(height * v, vmax), 8)
        cols = _cdiv(_cdiv(width * h, hmax), 8)
        out[i] = grid[:rows, :cols]
    return out


def _decode(d: bytes) -> np.ndarray:
    n = len(d)
    if n < 4 or d[0] != 0xFF or d[1] != 0xD8:
        raise JPEGError("not a JPEG file: missing SOI marker")
    quant: dict = {}
    huff: dict = {}
    frame = None
    restart = 0
    image = None
    pos = 2
    while True:  # every pass consumes at least one byte, so this ends
        if pos >= n:
            raise JPEGError("truncated JPEG: no EOI marker")
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
        if marker in _UNSUPPORTED_SOF:
            raise JPEGError(f"unsupported: {_UNSUPPORTED_SOF[marker]} (only baseline is decoded)")
        if marker in (0xC0, 0xC1):
            if frame is not None:
                raise JPEGError("corrupt JPEG: more than one frame header")
            frame = _parse_sof(seg, marker)
        elif marker == 0xC4:
            _parse_dht(seg, huff)
        elif marker == 0xDB:
            _parse_dqt(seg, quant)
        elif marker == 0xDD:
            if len(seg) != 2:
                raise JPEGError("corrupt DRI segment")
            restart = int.from_bytes(seg)
        elif marker == 0xDA:
            if frame is None:
                raise JPEGError("corrupt JPEG: scan before frame header")
            if image is not None:
                raise JPEGError("unsupported: more than one scan (only single-scan baseline)")
            end = _scan_end(d, pos)
            image = _decode_image(frame, seg, d[pos:end], quant, huff, restart)
            pos = end


def _decode_image(frame, sos: bytes, data: bytes, quant, huff, restart) -> np.ndarray:
    height, width, comps = frame
    if len(sos) < 1 or len(sos) != 4 + 2 * sos[0]:
        raise JPEGError("corrupt SOS segment")
    ns = sos[0]
    if ns != len(comps):
        raise JPEGError("unsupported: scan does not contain every component (multi-scan)")
    ss, se, ahal = sos[1 + 2 * ns :]
    if (ss, se, ahal) != (0, 63, 0):
        raise JPEGError("unsupported: spectral selection / successive approximation")
    ids = [c[0] for c in comps]
    order, schedule = [], []
    for j in range(ns):
        cid, tables = sos[1 + 2 * j], sos[2 + 2 * j]
        if cid not in ids or ids.index(cid) in order:
            raise JPEGError(f"corrupt SOS: unknown or repeated component {cid}")
        i = ids.index(cid)
        td, ta = tables >> 4, tables & 15
        if (0, td) not in huff or (1, ta) not in huff:
            raise JPEGError(f"corrupt JPEG: missing Huffman table for component {cid}")
        if comps[i][3] not in quant:
            raise JPEGError(f"corrupt JPEG: missing quantization table for component {cid}")
        order.append(i)
        blocks = 1 if ns == 1 else comps[i][1] * comps[i][2]
        schedule += [(j, td, ta)] * blocks
    if ns * 1 > 1 and sum(comps[i][1] * comps[i][2] for i in order) > 10:
        raise JPEGError("corrupt SOF: more than 10 blocks per MCU")
    hmax = max(c[1] for c in comps)
    vmax = max(c[2] for c in comps)
    if ns == 1:
        _, h, v, _ = comps[order[0]]
        n_mcu = _cdiv(_cdiv(height * v, vmax), 8) * _cdiv(_cdiv(width * h, hmax), 8)
    else:
        n_mcu = -(-width // (8 * hmax)) * -(-height // (8 * vmax))
    dcs, ac_index, ac_value = _decode_scan(data, schedule, n_mcu, restart, huff)
    coef = np.zeros((dcs.size, 64), np.int64)
    coef[:, 0] = dcs
    coef.reshape(-1)[ac_index] = ac_value
    per_comp = _blocks_per_component(coef, comps, order, height, width)
    factors = [(c[1], c[2]) for c in comps]
    tables = [quant[c[3]] for c in comps]
    planes = L.inverse([per_comp[i] for i in range(len(comps))], factors, tables, height, width, np)
    if len(planes) == 1:
        return planes[0].astype(np.uint8)
    return L.ycc_to_rgb(*planes, np)


def decode(data) -> np.ndarray:
    """Decode a baseline JPEG file exactly as libjpeg-turbo does by default (islow
    IDCT, fancy upsampling), e.g. as Pillow's `Image.open(...)`.

    **Arguments:**

    - `data`: the file's bytes (`bytes`, `bytearray` or `memoryview`).

    **Returns:**

    `(H, W, 3)` uint8 RGB, or `(H, W)` uint8 for a greyscale file.

    Raises `JPEGError` (a `ValueError`) for anything that is not a well-formed
    baseline (or extended sequential Huffman, 8-bit) JPEG with one scan: garbage,
    truncated files, bad tables, progressive, arithmetic-coded, lossless or 12-bit
    files. Every loop is bounded by the input length.
    """
    if not isinstance(data, bytes | bytearray | memoryview):
        raise TypeError(f"`data` must be bytes, got {type(data).__name__}")
    d = bytes(data)
    try:
        return _decode(d)
    except JPEGError:
        raise
    except (IndexError, ValueError, OverflowError, KeyError) as err:  # defensive net
        raise JPEGError(f"corrupt JPEG: {err}") from None
