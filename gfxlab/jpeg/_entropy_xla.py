"""Entropy decoding of a baseline scan as one compiled XLA program.

The same decoder as `_entropy._run` (the Python loop, kept for small images where
compiling would cost more than it saves), written as a `lax.while_loop` with one
iteration per Huffman symbol: XLA compiles the loop into native code, a few
nanoseconds per symbol instead of a Python interpreter's hundreds.

- The bits are read through a 32-bit window per byte (`b[i] << 24 | ... | b[i + 3]`,
  built inside the program from the padded bytes);
  shifted by the bit offset it holds at least 25 valid bits.
- Decoding is table driven in two levels, as in libjpeg: a `FAST_BITS`-bit lookup
  (16 KB for four tables: it stays in the L1 cache) gives the whole symbol (value,
  zig-zag step, bits consumed) when code and extra bits fit; the rare longer codes
  take the 16-bit table (`_lut`: code length, number of extra bits, zig-zag step; 0
  marks an invalid code) and then read their extra bits (at most 11).
- The loop state is two scalars and the coefficients: XLA compiles each output of
  the loop body into its own kernel, each recomputing the symbol's lookups, so fewer
  outputs are faster (on 512^2 RGB: 2.2 ms with nine, 1.4 ms with two). What depends
  on the block (its tables, where its restart interval's data end, where the next
  one starts, the slot of its DC prediction) is precomputed per block.
- Errors (an invalid code, a run past the end of a block, data ending inside a
  block) stop the loop with a status code that `decode_scan` turns into `JPEGError`,
  with the same messages as the Python loop.

Shapes are bucketed (`_bucket`, and the bit window is as long as the coefficient
array when the file fits in it) so that files of one image size share a compiled
program; the tables, the per-block plan and the segment starts are arguments.
"""

from __future__ import annotations

import functools

import numpy as np

from gfxlab._xla_options import legacy_cpu_emitters
from gfxlab.jpeg._entropy import _fast_table
from gfxlab.jpeg._tables import ZIGZAG

FAST_BITS = 10  # first-level lookup (9-10 measured fastest; 12 falls out of L1)
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
    fast = [_fast(t) for t in tables]
    fast += [fast[0]] * (len(luts) - len(fast))
    return jax.device_put(np.stack(fast)), jax.device_put(np.stack(luts))


def _fast(table) -> np.ndarray:
    """The first-level table of `table` over `FAST_BITS`-bit windows (small enough for
    the L1 cache): `value << 16 | step << 5 | bits consumed`, 0 where the code and its
    extra bits do not fit (the 16-bit table decodes those)."""
    cached = getattr(table, "xla_fast", None)
    if cached is None:
        lut16 = np.frombuffer(table.long, np.uint16)
        cached = _fast_table(lut16, int(table.ac), FAST_BITS).astype(np.int32)
        table.xla_fast = cached
    return cached


def decode_scan_compiled(stream, starts, plan, n_mcu: int, restart: int, dest: np.ndarray):
    """`_entropy.decode_scan`'s work after `segments`: `(status, bit, coefficients,
    stride)` (status 0: decoded). `coefficients` is a flat int16 device array in which
    natural position `n` of the block at scan position `b` sits at
    `n * stride + dest[b]` (two slots past them are scratch); it stays on the device, for
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
    # The window's length follows the image, not the file, where the file fits (up to
    # a byte per coefficient, past quality 95 of most photos): files of one image size
    # then share the program whatever their quality.
    needed = stream.size + 8
    window = _padded(stream, out_size if needed <= out_size else 1 << (needed - 1).bit_length())
    per_mcu = len(plan)
    interval = per_mcu * restart if restart else 1 << 30
    destinations, j, segment, last, previous = _block_layout(
        dest.tobytes(), stride, per_mcu, interval, tuple(ids[0, :per_mcu].tolist())
    )
    # Per block: its two tables, the bit where its restart interval's data end, for
    # the last block of an interval the bit where the next one starts (else -1), and
    # the slot of the DC it is predicted from.
    bounds = np.asarray(starts, np.int32)
    segment = np.minimum(segment, len(starts) - 2)
    per_block = np.empty((4, stride), np.int32)
    per_block[0] = (ids[1] | ids[2] << 3)[j]
    per_block[1] = bounds[segment + 1]
    per_block[2] = np.where(last, per_block[1], -1)
    per_block[3] = previous
    status, bit, coef = _program(out_size)(
        window, luts, per_block, destinations, np.int32(n_mcu * per_mcu)
    )
    return int(status), int(bit), coef, stride


@functools.lru_cache(maxsize=16)
def _block_layout(dest: bytes, stride: int, per_mcu: int, interval: int, component: tuple):
    """What a scan's geometry says of each block (cached per geometry): its
    destination, place in the MCU, restart interval, whether it ends one, and the slot
    of its DC prediction (the previous block of its component: in the same MCU or the
    one before; a zero slot, `64 * stride + 1`, at an interval's start)."""
    destinations = np.zeros(stride, np.int32)
    destinations[: len(dest) // 4] = np.frombuffer(dest, np.int32)
    block = np.arange(stride)
    j = block % per_mcu
    component = np.asarray(component)
    first = np.r_[True, component[1:] != component[:-1]]
    count = np.bincount(component, minlength=4)[component]
    previous = np.where(first[j], block - per_mcu + count[j] - 1, block - 1)
    starts_interval = first[j] & (block % interval < per_mcu)
    previous = np.where(starts_interval, 64 * stride + 1, destinations[np.maximum(previous, 0)])
    return destinations, j, block // interval, (block + 1) % interval == 0, previous


@functools.lru_cache(maxsize=32)
def _program(out_size: int):
    import jax
    import jax.numpy as jnp
    from jax import lax

    stride = out_size // 64
    natural = jnp.asarray(ZIGZAG, jnp.int32)

    def step(luts, window, per_block, dest, state):
        # One Huffman symbol; `pos` = 64 * block + zig-zag index (negative: -status).
        p, pos, out = state
        k, blk = pos & 63, pos >> 6
        dc = k == 0
        fast, luts = luts
        tables, segment_end, restart_at = per_block[0, blk], per_block[1, blk], per_block[2, blk]
        table = jnp.where(dc, tables & 7, tables >> 3)
        bits = window[p >> 3] << (p & 7).astype(jnp.uint32)
        f = fast[table, bits >> (32 - FAST_BITS)]
        # A long code (rare): the 16-bit table and the extra bits after the code; on a
        # hit both read a fixed, cached address, so they cost no cache miss.
        miss = f == 0
        e = luts[table, jnp.where(miss, bits >> 16, 0)]
        length, size, run = e & 31, (e >> 5) & 15, (e >> 9) & 31
        q = jnp.where(miss, p + length, 0)
        extra = (window[q >> 3] << (q & 7).astype(jnp.uint32)) >> (32 - size).astype(jnp.uint32)
        extra = extra.astype(jnp.int32)
        half = jnp.left_shift(1, jnp.maximum(size - 1, 0))
        value = jnp.where(size == 0, 0, jnp.where(extra < half, extra - (1 << size) + 1, extra))
        value = jnp.where(miss, value, f >> 16)
        run = jnp.where(miss, run, (f >> 5) & 31)
        p_next = p + jnp.where(miss, length + size, f & 31)
        k_next = jnp.where(dc, 1, jnp.where(run == 0, 64, k + run))
        slot = natural[jnp.where(dc, 0, k_next - 1)] * stride + dest[blk]
        done = k_next >= 64
        bad = jnp.where(miss & (e == 0), 2 - dc, jnp.where(k_next > 64, 3, 0))
        bad = jnp.where((bad == 0) & done & (p_next > segment_end), 4, bad)
        write = (bad == 0) & ((run > 0) | dc)  # an in-place update (no copy of `out`)
        # DC: the difference from the previous block of its component (a zero slot
        # at the start of a restart interval); the sum wraps to 16 bits like JCOEF.
        value = value.astype(jnp.int16) + jnp.where(dc, out[per_block[3, blk]], 0)
        out = out.at[jnp.where(write, slot, out_size)].set(value)
        p_next = jnp.where(done & (restart_at >= 0), restart_at, p_next)
        pos_next = jnp.where(done, pos - k + 64, pos - k + k_next)
        return jnp.where(bad > 0, p, p_next), jnp.where(bad > 0, -bad, pos_next), out

    @functools.partial(jax.jit, compiler_options=legacy_cpu_emitters())
    def run(stream, luts, per_block, dest, n_blocks):
        b = jnp.concatenate([stream, jnp.zeros(3, jnp.uint8)]).astype(jnp.uint32)
        window = b[:-3] << 24 | b[1:-2] << 16 | b[2:-1] << 8 | b[3:]
        state = (jnp.int32(0), jnp.int32(0), jnp.zeros(out_size + 2, jnp.int16))
        p, pos, out = lax.while_loop(
            lambda s: (s[1] >= 0) & (s[1] < 64 * n_blocks),
            lambda s: step(luts, window, per_block, dest, s),
            state,
        )
        status = jnp.maximum(-pos, 0)
        return status, p, out

    return run
