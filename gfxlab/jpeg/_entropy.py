"""Entropy decoding of a baseline (Huffman, 8-bit, sequential) scan.

Memory stays proportional to the image: the unstuffed scan bytes, one 24-bit window
per byte (a `uint32` array), and the coefficients, written straight into a
preallocated `(blocks, 64)` `int16` array in zig-zag order.

Decoding is table driven, as in libjpeg: a `LOOKAHEAD`-bit window indexes a table
whose entry holds, for the code that starts the window, the whole decoded symbol when
code and extra bits fit in the window (the bits consumed, the zig-zag step and the
value, packed in one int); the rare longer codes take a second lookup over 16 bits.
So one table lookup and a few integer operations decode most coefficients.
"""

from __future__ import annotations

import numpy as np

from gfxlab.jpeg._tables import ZIGZAG, huffman_codes

LOOKAHEAD = 12  # bits per first-level lookup
# From this many blocks on (512 x 512 grey: 4096), the scan is decoded by the compiled
# loop of `_entropy_xla` (compiled once per size bucket); fewer run in Python.
COMPILE_FROM_BLOCKS = 1024
_PAD_BYTES = 264  # slack past the end: one block reads at most 64 * 31 bits


class JPEGError(ValueError):
    """A JPEG stream is corrupt, truncated or uses a feature we do not decode."""


class HuffmanTable:
    """Decode tables of one DHT table: the packed first-level table (a list) and the
    16-bit `(length << 8) | symbol` table for long codes (a memoryview)."""

    def __init__(self, spec, table_class: int):
        try:
            codes = huffman_codes(spec)
        except ValueError as err:
            raise JPEGError(f"bad Huffman table: {err}") from None
        lut = np.zeros(1 << 16, np.uint16)
        for symbol, (code, length) in codes.items():
            if (table_class == 0 and symbol > 11) or (table_class == 1 and symbol & 15 > 10):
                continue  # never valid in a baseline stream; decoding it is an error
            lo = code << (16 - length)
            lut[lo : lo + (1 << (16 - length))] = (length << 8) | symbol
        self.long = memoryview(lut)
        self.fast = _fast_table(lut, table_class).tolist()
        self.ac = table_class == 1


def _extend(extra, size):
    """T.81's EXTEND: `size` extra bits -> the signed value."""
    return np.where(extra < (1 << np.maximum(size - 1, 0)), extra - (1 << size) + 1, extra)


def _packed(value, step, bits):
    """One table entry: value << 16 | zig-zag step << 5 | bits consumed (never 0)."""
    return (np.asarray(value, np.int64) << 16) | (np.asarray(step, np.int64) << 5) | bits


def _fast_table(lut16: np.ndarray, table_class: int, lookahead: int = LOOKAHEAD) -> np.ndarray:
    """The first-level table over all `lookahead`-bit windows; 0 where the code and
    its extra bits do not fit in the window (or no code matches)."""
    window = np.arange(1 << lookahead, dtype=np.int64)
    entry = lut16[window << (16 - lookahead)].astype(np.int64)
    length, symbol = entry >> 8, entry & 255
    size = symbol & 15 if table_class else symbol
    total = length + size
    fits = (length > 0) & (total <= lookahead)
    extra = (window >> np.maximum(lookahead - total, 0)) & ((1 << size) - 1)
    value = np.where(size > 0, _extend(extra, size), 0)
    if table_class == 0:
        step = np.ones_like(symbol)
    else:  # (run + 1) for a coefficient, 16 for ZRL, 0 for EOB (libjpeg: any r != 15, s = 0)
        run = symbol >> 4
        step = np.where(size > 0, run + 1, np.where(run == 15, 16, 0))
    return np.where(fits, _packed(value, step, total), 0)


def _long_code(window, p: int, table: HuffmanTable) -> int:
    """Packed entry of a code that did not fit the first-level lookup."""
    w = (window[p >> 3] >> (8 - (p & 7))) & 0xFFFF
    e = table.long[w]
    if not e:
        kind = "AC" if table.ac else "DC"
        raise JPEGError(f"corrupt JPEG: invalid {kind} Huffman code at bit {p}")
    length, symbol = e >> 8, e & 255
    size = symbol & 15 if table.ac else symbol
    q = p + length
    extra = ((window[q >> 3] >> (8 - (q & 7))) & 0xFFFF) >> (16 - size) if size else 0
    value = extra - (1 << size) + 1 if size and extra < (1 << (size - 1)) else extra
    if not table.ac:
        step = 1
    else:
        run = symbol >> 4
        step = run + 1 if size else (16 if run == 15 else 0)
    return (value << 16) | (step << 5) | (length + size)


def segments(data: bytes) -> tuple[np.ndarray, list[int]]:
    """Split entropy-coded data at RST markers and remove the 0xFF00 stuffing.

    **Returns:** the concatenated bytes and the start bit of each segment (plus the end).
    """
    arr = np.frombuffer(data, np.uint8)
    is_ff = arr == 0xFF
    nxt = np.concatenate([arr[1:], [0]]).astype(np.uint8)
    rst = np.flatnonzero(is_ff & (nxt >= 0xD0) & (nxt <= 0xD7))
    stuffed = np.flatnonzero(is_ff[:-1] & (arr[1:] == 0)) + 1
    keep = np.ones(arr.size, bool)
    keep[stuffed] = False
    keep[rst] = False
    keep[rst + 1] = False
    kept_before = np.concatenate([[0], np.cumsum(keep)])
    starts = (8 * kept_before[np.concatenate([[0], rst + 2])]).tolist()
    stream = arr[keep]
    starts.append(8 * stream.size)
    return stream, starts


def windows(stream: np.ndarray) -> memoryview:
    """A 24-bit window `b[i] << 16 | b[i + 1] << 8 | b[i + 2]` per byte (zero padded)."""
    padded = np.zeros(stream.size + _PAD_BYTES, np.uint32)
    padded[: stream.size] = stream
    out = (padded[:-2] << 16) | (padded[1:-1] << 8) | padded[2:]
    return memoryview(out)


def decode_scan(data: bytes, plan, n_mcu: int, restart: int, dest: np.ndarray, *, compiled=None):
    """Entropy-decode one interleaved (or single-component) baseline scan.

    **Arguments:**

    - `data`: the entropy-coded bytes (stuffed, with RST markers).
    - `plan`: per block of an MCU, `(component, dc HuffmanTable, ac HuffmanTable)`.
    - `n_mcu`: MCUs in the scan; `restart`: the restart interval (0: none).
    - `dest`: `(blocks,)` where each block (in scan order) goes in the output.
    - `compiled`: decode with the compiled loop (`True`), in Python (`False`), or from
      `COMPILE_FROM_BLOCKS` blocks on (`None`).

    **Returns:**

    `(coefficients, stride)`: flat int16 quantized coefficients, natural position `n`
    of the block at scan position `b` at `n * stride + dest[b]` (a device array from
    the compiled loop, else NumPy), DC values already predicted (wrapped to 16 bits
    as libjpeg's `JCOEF`).
    """
    stream, starts = segments(data)
    n_bits = starts[-1]
    n_blocks = n_mcu * len(plan)
    if 2 * n_blocks > n_bits:  # every block takes at least two bits: bounds the memory
        raise JPEGError(
            f"truncated JPEG: {n_blocks} blocks cannot fit in {n_bits} bits of scan data"
        )
    if restart and -(-n_mcu // restart) > len(starts) - 1:
        raise JPEGError("truncated JPEG: missing restart interval")
    if n_blocks >= COMPILE_FROM_BLOCKS if compiled is None else compiled:
        from gfxlab.jpeg._entropy_xla import _MESSAGES, decode_scan_compiled

        status, bit, coef, stride = decode_scan_compiled(stream, starts, plan, n_mcu, restart, dest)
        if status:
            raise JPEGError(_MESSAGES[status].format(bit))
        return coef, stride
    coef = np.zeros((n_blocks, 64), np.int16)
    _run(windows(stream), starts, n_mcu, restart, plan, memoryview(coef.reshape(-1)))
    planar = np.empty((64, n_blocks), np.int16)
    planar[ZIGZAG[:, None], dest[None, :]] = coef.T
    return planar.reshape(-1), n_blocks


def _run(window, starts, n_mcu, restart, plan, out) -> None:  # noqa: C901 (the hot loop)
    shift, mask = 24 - LOOKAHEAD, (1 << LOOKAHEAD) - 1
    steps = [(c, dc.fast, dc, ac.fast, ac) for c, dc, ac in plan]
    pred = [0] * 4
    p, segment, seg_end, base = 0, 0, starts[1], 0
    for mcu in range(n_mcu):
        if restart and mcu and mcu % restart == 0:
            segment += 1
            p, seg_end = starts[segment], starts[segment + 1]
            pred = [0] * 4
        for c, dc_fast, dc, ac_fast, ac in steps:
            e = dc_fast[(window[p >> 3] >> (shift - (p & 7))) & mask]
            if not e:
                e = _long_code(window, p, dc)
            p += e & 31
            v = pred[c] + (e >> 16)
            pred[c] = v
            out[base] = ((v + 32768) & 0xFFFF) - 32768
            k = base + 1
            end = base + 64
            while k < end:
                e = ac_fast[(window[p >> 3] >> (shift - (p & 7))) & mask]
                if not e:
                    e = _long_code(window, p, ac)
                p += e & 31
                step = (e >> 5) & 31
                if not step:
                    break
                k += step
                if k > end:
                    raise JPEGError("corrupt JPEG: AC run past the end of a block")
                out[k - 1] = e >> 16
            base = end
            if p > seg_end:
                raise JPEGError("truncated or corrupt JPEG: scan data ended inside a block")
