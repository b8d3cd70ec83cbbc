"""Entropy decoding of a baseline scan as one compiled XLA program.

The same decoder as `_entropy._run` (the Python loop, kept for small images where
compiling would cost more than it saves), written as a `lax.while_loop` with one
iteration per Huffman symbol: XLA compiles the loop into native code, a few
nanoseconds per symbol instead of a Python interpreter's hundreds.

- The bits are read through a 32-bit window per byte (`b[i] << 24 | ... | b[i + 3]`,
  built inside the program from the padded bytes);
  shifted by the bit offset it holds at least 25 valid bits: a 16-bit code lookup,
  then the extra bits (at most 11) after the code.
- Each Huffman table is a 16-bit lookup table whose entry packs the code length, the
  number of extra bits and the zig-zag step (`_lut`); 0 marks an invalid code.
- Errors (an invalid code, a run past the end of a block, data ending inside a
  block) stop the loop with a status code that `decode_scan` turns into `JPEGError`,
  with the same messages as the Python loop.

Shapes are bucketed (`_bucket`, and the bit window is as long as the coefficient
array when the file fits in it) so that files of one image size share a compiled
program; the tables, the block plan, the restart interval and the segment starts are
arguments.
"""

from __future__ import annotations

import functools

import numpy as np

from gfxlab.jpeg._tables import ZIGZAG

_MAX_PLAN = 10  # blocks per MCU (T.81's limit)
_MESSAGES = {
    1: "corrupt JPEG: invalid DC Huffman code at bit {}",
    2: "corrupt JPEG: invalid AC Huffman code at bit {}",
    3: "corrupt JPEG: AC run past the end of a block",
    4: "truncated or corrupt JPEG: scan data ended inside a block",
}


def _lut(table) -> np.ndarray:
    """`length | size << 5 | step << 9 | 1 << 14` per 16-bit window, from a
    `HuffmanTable`'s `(length << 8) | symbol` table (0: no valid code); kept on the
    table (the decoder caches tables by their spec)."""
    cached = getattr(table, "xla_lut", None)
    if cached is not None:
        return cached
    entry = np.frombuffer(table.long, np.uint16).astype(np.int32)
    length, symbol = entry >> 8, entry & 255
    if table.ac:
        size, run = symbol & 15, symbol >> 4
        step = np.where(size > 0, run + 1, np.where(run == 15, 16, 0))
    else:
        size, step = symbol, np.ones_like(symbol)
    table.xla_lut = np.where(entry > 0, length | size << 5 | step << 9 | 1 << 14, 0)
    table.xla_lut = table.xla_lut.astype(np.int32)
    return table.xla_lut


def _bucket(n: int, minimum: int) -> int:
    """`n` rounded up to a multiple of an eighth of its power of two (<= 12.5% more)."""
    n = max(n, minimum)
    step = 1 << max(n.bit_length() - 4, 0)
    return -(-n // step) * step


def _padded(stream: np.ndarray, size: int) -> np.ndarray:
    """The scan's bytes, zero-padded to `size` (the program builds its bit windows)."""
    padded = np.zeros(size, np.uint8)
    padded[: stream.size] = stream
    return padded


@functools.lru_cache(maxsize=16)
def _device_luts(tables: tuple):
    """The stacked lookup tables of `tables` (`HuffmanTable`s, which the decoder caches
    by their spec: the key holds them, so their ids stay theirs), on the device."""
    import jax

    luts = [_lut(t) for t in tables]
    # 4 tables (256 KB each) cover the usual files; at most 8 distinct in a scan
    luts += [luts[0]] * ((4 if len(luts) <= 4 else 8) - len(luts))
    return jax.device_put(np.stack(luts))


def decode_scan_compiled(stream, starts, plan, n_mcu: int, restart: int, dest: np.ndarray):
    """`_entropy.decode_scan`'s work after `segments`: `(status, bit, coefficients,
    stride)` (status 0: decoded). `coefficients` is a flat int16 device array in which
    natural position `n` of the block at scan position `b` sits at
    `n * stride + dest[b]` (one slot past them is scratch); it stays on the device, for
    the compiled reconstruction."""
    n_blocks = dest.size
    tables, index = [], {}
    ids = np.zeros((3, _MAX_PLAN), np.int32)
    for j, (component, dc, ac) in enumerate(plan):
        for row, table in ((1, dc), (2, ac)):
            if id(table) not in index:
                index[id(table)] = len(tables)
                tables.append(table)
            ids[row, j] = index[id(table)]
        ids[0, j] = component
    luts = _device_luts(tuple(tables))
    stride = _bucket(n_blocks, 1 << 10)
    out_size = stride * 64
    destinations = np.zeros(stride, np.int32)
    destinations[:n_blocks] = dest
    # The window's length follows the image, not the file, where the file fits (up to
    # a byte per coefficient, past quality 95 of most photos): files of one image size
    # then share the program whatever their quality.
    needed = stream.size + 8
    window = _padded(stream, out_size if needed <= out_size else 1 << (needed - 1).bit_length())
    starts = np.asarray(starts + [starts[-1]] * 2, np.int32)
    seg = np.zeros(_bucket(starts.size, 8), np.int32)
    seg[: starts.size] = starts
    seg[starts.size :] = starts[-1]
    program = _program(out_size)
    status, bit, coef = program(
        window, luts, ids, seg, destinations, np.array([len(plan), n_mcu, restart], np.int32)
    )
    return int(status), int(bit), coef, stride


@functools.lru_cache(maxsize=32)
def _program(out_size: int):
    import jax
    import jax.numpy as jnp
    from jax import lax

    stride = out_size // 64
    natural = jnp.asarray(ZIGZAG, jnp.int32)

    def step(luts, window, ids, seg, dest, sizes, state):
        p, k, blk, j, mcu, segment, status, pred, out = state
        per_mcu, _, restart = sizes[0], sizes[1], sizes[2]
        dc = k == 0
        table = jnp.where(dc, ids[1, j], ids[2, j])
        e = luts[table, (window[p >> 3] << (p & 7).astype(jnp.uint32)) >> 16]
        length, size, run = e & 31, (e >> 5) & 15, (e >> 9) & 31
        q = p + length
        extra = (window[q >> 3] << (q & 7).astype(jnp.uint32)) >> (32 - size).astype(jnp.uint32)
        extra = extra.astype(jnp.int32)
        half = jnp.left_shift(1, jnp.maximum(size - 1, 0))
        value = jnp.where(size == 0, 0, jnp.where(extra < half, extra - (1 << size) + 1, extra))
        c = ids[0, j]
        dc_value = pred[c] + value
        pred = jnp.where(dc, pred.at[c].set(dc_value), pred)
        k_next = jnp.where(dc, 1, jnp.where(run == 0, 64, k + run))
        slot = natural[jnp.where(dc, 0, k_next - 1)] * stride + dest[blk]
        written = jnp.where(dc, dc_value, value).astype(jnp.int16)  # wraps like JCOEF
        bad = jnp.where(e == 0, jnp.where(dc, 1, 2), jnp.where(k_next > 64, 3, 0))
        write = (bad == 0) & ((run > 0) | dc)  # an in-place update (no copy of `out`)
        out = out.at[jnp.where(write, slot, out.shape[0] - 1)].set(written)  # last: a dummy
        p = q + size
        done = k_next >= 64
        bad = jnp.where((bad == 0) & done & (p > seg[segment + 1]), 4, bad)
        j_next = jnp.where(done, j + 1, j)
        wrap = j_next == per_mcu
        mcu = jnp.where(wrap, mcu + 1, mcu)
        j_next = jnp.where(wrap, 0, j_next)
        restart_now = wrap & (restart > 0) & (mcu % jnp.maximum(restart, 1) == 0)
        segment = jnp.where(restart_now, segment + 1, segment)
        p = jnp.where(restart_now, seg[segment], p)
        pred = jnp.where(restart_now, 0, pred)
        status = jnp.where(bad > 0, bad, status)
        k_next = jnp.where(done, 0, k_next)
        blk = jnp.where(done, blk + 1, blk)
        return (jnp.where(bad > 0, p - length - size, p), k_next, blk, j_next, mcu, segment,
                status, pred, out)  # fmt: skip

    @jax.jit
    def run(stream, luts, ids, seg, dest, sizes):
        b = jnp.concatenate([stream, jnp.zeros(3, jnp.uint8)]).astype(jnp.uint32)
        window = b[:-3] << 24 | b[1:-2] << 16 | b[2:-1] << 8 | b[3:]
        zero = jnp.int32(0)
        state = (zero, zero, zero, zero, zero, zero, zero, jnp.zeros(4, jnp.int32),
                 jnp.zeros(out_size + 1, jnp.int16))  # fmt: skip
        state = lax.while_loop(
            lambda s: (s[6] == 0) & (s[4] < sizes[1]),
            lambda s: step(luts, window, ids, seg, dest, sizes, s),
            state,
        )
        return state[6], state[0], state[8]

    return run
