"""The baseline encoder's dense core: pixels in, one Huffman event per coefficient.

A baseline scan is a sequence of Huffman "events": per block a DC difference, then for
each nonzero AC coefficient its ZRLs (one per 16 preceding zeros) and its (run, size)
symbol, then an EOB if the block ends in zeros. Each of those can be given a fixed slot
among the block's 64 zig-zag positions, so the whole scan fits a static
`(blocks, 64)` array and needs no data-dependent shapes:

- slot 0 holds the DC difference;
- a nonzero AC coefficient holds its own (run, size) code and extra bits;
- the zero that completes each run of 16 before a later nonzero holds a ZRL;
- the slot right after the last nonzero holds the EOB.

A slot holds `(symbol index + 1) << 11 | extra bits` as one uint32 (0: no event); the
Huffman tables are looked up only after the empty slots are dropped. The same code runs
in NumPy (small images, no compilation) and as jitted XLA programs (large images);
`pack_scan` then drops the empty slots, looks the codes up and concatenates the bits.
Large images go in horizontal bands of MCU rows (`band_plan`), so that NumPy packs one
band while XLA computes the next; only DC prediction crosses bands (`pack_bands`).

Everything that depends on the image size is static; the quantization divisors are
arguments, so all qualities share the compiled programs of an image size.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from gfxlab.jpeg import _libjpeg as L
from gfxlab.jpeg._tables import (
    AC_CHROMINANCE,
    AC_LUMINANCE,
    DC_CHROMINANCE,
    DC_LUMINANCE,
    ZIGZAG,
    huffman_codes,
)


def _symbol_table(spec, size: int, dc: bool) -> np.ndarray:
    """`(code << 10) | (extra bits << 5) | code length` per symbol (0: no code)."""
    table = np.zeros(size, np.int64)
    for symbol, (code, length) in huffman_codes(spec).items():
        extra = symbol if dc else symbol & 15
        table[symbol] = code << 10 | extra << 5 | length
    return table


# Indexed by 256 * AC table id + AC symbol, or 512 + 16 * DC table id + DC category
# (table 0 luminance, 1 chrominance).
_SYMBOLS = np.concatenate(
    [_symbol_table(spec, 256, False) for spec in (AC_LUMINANCE, AC_CHROMINANCE)]
    + [_symbol_table(spec, 16, True) for spec in (DC_LUMINANCE, DC_CHROMINANCE)]
)
_EXTRA_BITS = 11  # at most 11 extra bits (a DC difference); the symbol index above them
# Per event index (symbol index + 1; 0 unused): the code shifted past its extra bits,
# and code length + extra bits.
_CODE_SHIFTED = np.concatenate([[0], _SYMBOLS >> 10 << (_SYMBOLS >> 5 & 31)]).astype(np.uint64)
_LENGTHS = np.concatenate([[0], (_SYMBOLS & 31) + (_SYMBOLS >> 5 & 31)])


class _Slots:
    """Constants for 63 AC slots whose zig-zag positions are `positions`: where each
    position's bit sits in a 64-bit mask held as two 32-bit words, and the masks of
    the positions below it in each word."""

    def __init__(self, positions: np.ndarray):
        self.positions = positions.astype(np.int32)
        self.in_lo = positions < 32
        self.bit_in_word = (positions % 32).astype(np.uint32)
        self.below_lo = np.array([(1 << min(p, 32)) - 1 for p in positions], np.uint64)
        self.below_lo = self.below_lo.astype(np.uint32)
        self.below_hi = np.array([(1 << max(p - 32, 0)) - 1 for p in positions], np.uint32)


# `_fdct` leaves coefficient (v, u) at 8 * u + v; the zig-zag gather reads it from there.
_ZIGZAG_TRANSPOSED = np.array([8 * (n % 8) + n // 8 for n in ZIGZAG.tolist()])
_IN_ZIGZAG_ORDER = _Slots(np.arange(1, 64))
_IN_FDCT_ORDER = _Slots(np.argsort(_ZIGZAG_TRANSPOSED)[1:])  # zig-zag position per slot


def _bit_length(x, xp):
    """Bits needed for the unsigned 32-bit values `x` (0 for 0)."""
    if xp is np:
        return np.frexp(x.astype(np.float64))[1].astype(np.int64)  # exact below 2**53
    import jax.lax as lax

    return (32 - lax.clz(x.astype(np.uint32))).astype(np.int32)


def _magnitude_bits(value, xp):
    """JPEG's (size, extra bits) of signed values: negative v is coded as v + 2**size - 1."""
    size = _bit_length(xp.abs(value).astype(np.uint32), xp)
    extra = xp.where(value < 0, value + xp.left_shift(1, size) - 1, value)
    return size, extra.astype(np.uint32)


def _nonzero_words(nonzero, slots: _Slots, xp):
    """`(N, 63)` nonzero flags of the AC slots -> two uint32 words per block: bit p of
    the 64-bit mask marks a nonzero at zig-zag position p; bit 0 stands for the DC and
    is always set, so that "previous nonzero" defaults to position 0."""
    flags = xp.left_shift(nonzero.astype(np.uint32), slots.bit_in_word)
    lo_flags = xp.where(slots.in_lo, flags, np.uint32(0))
    hi_flags = xp.where(slots.in_lo, np.uint32(0), flags)
    if xp is np:
        lo, hi = lo_flags.sum(axis=1, dtype=np.uint32), hi_flags.sum(axis=1, dtype=np.uint32)
    else:  # one pass over the flags for both words
        import jax.lax as lax

        zero = np.uint32(0)
        lo, hi = lax.reduce(
            (lo_flags, hi_flags), (zero, zero), lambda a, b: (a[0] | b[0], a[1] | b[1]), (1,)
        )
    return lo | np.uint32(1), hi


def block_events(coefficients, dc_difference, table_ids, xp, *, order: str = "zigzag"):
    """Huffman events of blocks, one slot per coefficient.

    **Arguments:**

    - `coefficients`: `(N, 64)` quantized coefficients (column 0, the DC, ignored) in
      zig-zag order, or with `order="fdct"` as `_fdct` lays them out; the events come
      out in the same order.
    - `dc_difference`: `(N,)` DC minus the previous block's DC of the same component.
    - `table_ids`: `(N,)` Huffman table of each block (0 luminance, 1 chrominance).
    - `xp`: `numpy` or `jax.numpy`.

    **Returns:**

    `(N, 64)` uint32 events `(symbol index + 1) << 11 | extra bits`, 0 where a slot
    emits nothing; the symbol index points into `_SYMBOLS`, looked up after compaction.
    """
    slots = {"zigzag": _IN_ZIGZAG_ORDER, "fdct": _IN_FDCT_ORDER}[order]
    ac = coefficients[:, 1:]
    nonzero = ac != 0
    lo, hi = _nonzero_words(nonzero, slots, xp)
    hi_below = hi[:, None] & slots.below_hi
    previous = xp.where(
        hi_below != 0,
        31 + _bit_length(hi_below, xp),
        _bit_length(lo[:, None] & slots.below_lo, xp) - 1,
    )
    last = xp.where(hi != 0, 31 + _bit_length(hi, xp), _bit_length(lo, xp) - 1)[:, None]
    positions = slots.positions
    run = positions - previous - 1

    size, extra = _magnitude_bits(ac, xp)
    t = xp.asarray(table_ids).astype(np.int32)
    ac_base = (t * 256 + 1)[:, None]  # + 1: 0 stays "no event"
    symbol = xp.left_shift(run & 15, 4) | size
    zrl = ~nonzero & (positions < last) & (((positions - previous) & 15) == 0)
    eob = positions == last + 1
    index = xp.where(nonzero, symbol, xp.where(zrl, 0xF0, 0)) + ac_base
    index = xp.where(nonzero | zrl | eob, index, 0).astype(np.uint32)
    events = xp.left_shift(index, _EXTRA_BITS) | extra

    dc_size, dc_extra = _magnitude_bits(dc_difference, xp)
    dc = xp.left_shift((512 + 1 + t * 16 + dc_size).astype(np.uint32), _EXTRA_BITS) | dc_extra
    return xp.concatenate([dc[:, None], events], axis=1)


def _nonempty(events: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The non-empty events, in stream order (a writable copy), and the emptiness mask."""
    flat = events.reshape(-1)
    mask = flat != 0
    return np.compress(mask, flat), mask


def _place(events: np.ndarray, first_bit: int) -> tuple[int, np.ndarray, int]:
    """Non-empty events whose bits start at `first_bit` -> (first 32-bit word, the words
    from there on as float64 sums, number of bits).

    Each code (<= 26 bits) straddles at most two words: put it in a 64-bit window that
    starts at its first word and split that. Codes never share bits, so a word is the
    sum of its pieces (float64 is exact below 2**53).
    """
    index = events >> _EXTRA_BITS
    bits = _CODE_SHIFTED[index] | (events & ((1 << _EXTRA_BITS) - 1))
    lengths = _LENGTHS[index]
    end = np.cumsum(lengths) + first_bit
    start = end - lengths
    first_word = first_bit >> 5
    word = (start >> 5) - first_word
    window = bits << (64 - (start & 31) - lengths).astype(np.uint64)
    n_words = ((int(end[-1]) if end.size else first_bit) >> 5) - first_word + 2
    words = np.bincount(word, (window >> np.uint64(32)).astype(np.float64), n_words)
    words += np.bincount(word + 1, (window & np.uint64(0xFFFFFFFF)).astype(np.float64), n_words)
    return first_word, words, int(lengths.sum())


def _finish(placed: list[tuple[int, np.ndarray, int]]) -> bytes:
    """Words of consecutive pieces -> bytes, padded with 1-bits and 0xFF-stuffed."""
    total = sum(n for _, _, n in placed)
    words = np.zeros((total >> 5) + 2)
    for first_word, piece, _ in placed:
        words[first_word : first_word + piece.size] += piece[: words.size - first_word]
    data = words.astype(np.uint32).astype(">u4").view(np.uint8)[: -(-total // 8)].copy()
    if total % 8:
        data[-1] |= (1 << (-total % 8)) - 1
    ff = np.flatnonzero(data == 0xFF)
    if ff.size:
        data = np.insert(data, ff + 1, 0)
    return data.tobytes()


def pack_scan(events: np.ndarray) -> bytes:
    """Entropy-coded segment from events in stream order: concatenate the bits MSB
    first, pad the last byte with 1-bits, stuff a 0x00 after every 0xFF."""
    return _finish([_place(_nonempty(events)[0], 0)])


def _dc_event(difference: int, table: int) -> int:
    size = abs(difference).bit_length()
    extra = difference if difference >= 0 else difference + (1 << size) - 1
    return (512 + 1 + 16 * table + size) << _EXTRA_BITS | extra


def pack_bands(results, plan: list[tuple[int, Layout]]) -> bytes:
    """Entropy-coded segment from the results of `compiled_band_events`, one per band of
    `plan`, in order. Each band predicted its first DCs from 0; those DC differences
    are recomputed from the previous band's last DCs. A band is packed as soon as it is
    ready, while XLA still works on the later ones."""
    placed, previous_last, bit = [], None, 0
    for (events, first_dc, last_dc), (_, lay) in zip(results, plan, strict=True):
        events, mask = _nonempty(np.asarray(events))
        first_dc, last_dc = np.asarray(first_dc), np.asarray(last_dc)
        if previous_last is not None:
            block = 0
            for c, comp in enumerate(lay.components):
                at = int(np.count_nonzero(mask[: 64 * block]))
                events[at] = _dc_event(int(first_dc[c]) - int(previous_last[c]), comp.table)
                block += comp.factors[0] * comp.factors[1]
        previous_last = last_dc
        placed.append(_place(events, bit))
        bit += placed[-1][2]
    return _finish(placed)


# --- static layout ----------------------------------------------------------------------


@dataclass(frozen=True)
class _Component:
    factors: tuple[int, int]  # (h, v) sampling factors (1, 1 when not interleaved)
    step: tuple[int, int]  # downsampling (horizontal, vertical)
    rows_in: int  # rows of the full-resolution plane that are downsampled
    cols_in: int
    blocks: tuple[int, int]  # real blocks (rows, cols)
    grid: tuple[int, int]  # blocks including the MCU padding (rows, cols)
    table: int  # Huffman / quantization table id


@dataclass(frozen=True, eq=False)
class Layout:
    """Everything `encode` needs to know about an image size, as static numbers."""

    components: tuple[_Component, ...]
    mcus: tuple[int, int]  # MCU rows, MCU columns (1 x 1 blocks when not interleaved)
    padded: tuple[int, int]  # input size after edge replication
    table_ids: np.ndarray  # (blocks,) Huffman table of each block, scan order
    dc_source: np.ndarray  # (blocks,) block whose DC each block carries (dummies copy)
    dummy: np.ndarray  # (blocks,) libjpeg's zero-AC padding blocks

    @property
    def interleaved(self) -> bool:
        return len(self.components) > 1


def _scan_index(lay_mcus, comp: _Component, offset: int, blocks_per_mcu: int) -> np.ndarray:
    """Scan position of every block of a component's grid `(grid rows, grid cols)`."""
    h, v = comp.factors
    rows, cols = np.indices(comp.grid)
    mcu = (rows // v) * lay_mcus[1] + cols // h
    return mcu * blocks_per_mcu + offset + (rows % v) * h + cols % h


@functools.lru_cache(maxsize=256)
def layout(height: int, width: int, factors: tuple[tuple[int, int], ...]) -> Layout:
    """libjpeg's geometry (jcmaster.c, jcprepct.c, jccoefct.c) for an image size.

    `factors` lists `(h, v)` per component; a lone component is coded without MCU
    interleaving, whatever factors its header records.
    """
    interleaved = len(factors) > 1
    if not interleaved:
        factors = ((1, 1),)
    hmax, vmax, geometry = L.component_layout(height, width, factors)
    mcu_x = -(-width // (8 * hmax))
    mcu_y = -(-height // (8 * vmax))
    components = []
    for c, ((h, v), _, (bh, bw)) in enumerate(geometry):
        grid = (mcu_y * v, mcu_x * h) if interleaved else (bh, bw)
        step = (hmax // h, vmax // v)
        rows_in = -(-height // vmax) * vmax
        components.append(
            _Component((h, v), step, rows_in, bw * 8 * step[0], (bh, bw), grid, min(c, 1))
        )
    mcus = (mcu_y, mcu_x) if interleaved else components[0].blocks
    per_mcu = sum(c.factors[0] * c.factors[1] for c in components)
    n_blocks = mcus[0] * mcus[1] * per_mcu
    table_ids = np.zeros(n_blocks, np.int32)
    dc_source = np.arange(n_blocks)
    dummy = np.zeros(n_blocks, bool)
    offset = 0
    for comp in components:
        index = _scan_index(mcus, comp, offset, per_mcu)
        table_ids[index] = comp.table
        # jccoefct.c: a dummy block right of the image copies the DC of the last real
        # block in its row; a dummy row below copies, per MCU, the DC of the block
        # above the MCU's last column.
        source = index.copy()
        rows, cols = comp.blocks
        source[:, cols:] = source[:, cols - 1 : cols]
        h = comp.factors[0]
        for r in range(rows, comp.grid[0]):
            source[r] = np.repeat(source[r - 1, h - 1 :: h], h)
        dc_source[index] = source
        dummy[index] = True
        dummy[index[:rows, :cols]] = False
        offset += comp.factors[0] * comp.factors[1]
    rows = max(c.grid[0] * 8 * c.step[1] for c in components)
    cols = max(c.grid[1] * 8 * c.step[0] for c in components)
    return Layout(tuple(components), mcus, (rows, cols), table_ids, dc_source, dummy)


def pad_input(image: np.ndarray, lay: Layout) -> np.ndarray:
    """Edge-replicate the image to `lay.padded` (colour conversion is per pixel, so this
    equals libjpeg's replication of the converted planes; what lands in dummy blocks
    is replaced)."""
    rows, cols = lay.padded
    if image.shape[:2] == (rows, cols):
        return image
    pad = [(0, rows - image.shape[0]), (0, cols - image.shape[1])] + [(0, 0)] * (image.ndim - 2)
    return np.pad(image, pad, mode="edge")


def quantizers(tables) -> np.ndarray:
    """libjpeg-turbo's reciprocal divisors per component: `(components, 3, 8, 8)` for
    (reciprocal, correction, shift), indexed like the transposed coefficients of
    `_fdct`, (horizontal, vertical) frequency."""
    return np.stack([np.stack(L.reciprocals(t)).swapaxes(1, 2) for t in tables]).astype(np.uint32)


def _fdct(blocks, xp):
    """jfdctint.c on level-shifted `(..., 8, 8)` samples; the output is transposed,
    `[..., u, v]` for horizontal frequency u and vertical frequency v (the column pass
    reads the row pass's output transposed, and that is its natural layout)."""
    # The butterflies on whole columns of the block stack, as jfdctint.c runs them on
    # one row: exact 32-bit integer arithmetic, elementwise (an integer matrix product
    # is several times slower in XLA on CPU, and float32 is not exact here).
    rows = xp.stack(L._fdct_1d([blocks[..., j] for j in range(8)]), axis=-1)
    rows = L._descale(rows, L.CONST_BITS - L.PASS1_BITS, xp)
    out = xp.stack(L._fdct_1d([rows[..., j, :] for j in range(8)]), axis=-1)
    return L._descale(out, L.CONST_BITS + L.PASS1_BITS, xp)


def scan_coefficients(image, divisors, lay: Layout, xp):
    """Quantized coefficients `(blocks in scan order, 64)`, laid out as `_fdct` leaves
    them, of an edge-padded uint8 image, and the DC differences `(blocks,)` the scan
    codes.

    **Arguments:**

    - `image`: `pad_input(image, lay)`, `(rows, cols)` grey or `(rows, cols, 3)` RGB.
    - `divisors`: `quantizers(tables)`, one set per component.
    - `lay`: `layout(...)` of the unpadded size.
    - `xp`: `numpy` or `jax.numpy`.
    """
    planes = [image.astype(np.int32)] if image.ndim == 2 else list(L.rgb_to_ycc(image, xp))
    mcu_rows, mcu_cols = lay.mcus
    per_mcu, component = [], []
    for c, (plane, comp) in enumerate(zip(planes, lay.components, strict=True)):
        (fh, fv), (h, v) = comp.step, comp.factors
        small = L.downsample(plane[: comp.rows_in, : comp.cols_in], fh, fv, xp)
        small = L.pad_edge(small, comp.grid[0] * 8, comp.grid[1] * 8, xp).astype(np.int32)
        # Pixels straight into scan order: (MCU, block in MCU, 8, 8).
        cells = small.reshape(mcu_rows, v, 8, mcu_cols, h, 8).transpose(0, 3, 1, 4, 2, 5)
        per_mcu.append(cells.reshape(mcu_rows * mcu_cols, v * h, 8, 8) - 128)
        component += [c] * (v * h)
    coefficients = _fdct(xp.concatenate(per_mcu, axis=1), xp)  # (MCU, block, 8, 8)
    recip, corr, shift = xp.moveaxis(xp.asarray(divisors)[np.array(component)], 1, 0)
    magnitude = xp.abs(coefficients).astype(np.uint32)
    quantized = xp.right_shift((magnitude + corr) * recip, shift).astype(np.int32)
    quantized = xp.where(coefficients < 0, -quantized, quantized).reshape(-1, 64)
    quantized = xp.where(lay.dummy[:, None], 0, quantized).astype(np.int16)  # |q| <= 2047
    dc = quantized[:, 0][lay.dc_source].reshape(mcu_rows * mcu_cols, len(component))
    dc_difference = []
    for c in range(len(lay.components)):
        own = dc[:, np.flatnonzero(np.array(component) == c)]
        flat = own.reshape(-1)
        previous = xp.concatenate([xp.zeros(1, flat.dtype), flat[:-1]])
        dc_difference.append((flat - previous).reshape(own.shape))
    return quantized, xp.concatenate(dc_difference, axis=1).reshape(-1)


def _edge_dcs(quantized, lay: Layout, xp):
    """DC of the first and of the last block of each component, in scan order."""
    per_mcu = sum(c.factors[0] * c.factors[1] for c in lay.components)
    dc = quantized[:, 0][lay.dc_source]
    first, last, offset = [], [], 0
    for comp in lay.components:
        count = comp.factors[0] * comp.factors[1]
        first.append(offset)
        last.append(dc.shape[0] - per_mcu + offset + count - 1)
        offset += count
    return dc[np.array(first)].astype(np.int32), dc[np.array(last)].astype(np.int32)


def _zigzag(transposed):
    """Coefficients `(N, 64)` as `_fdct` lays them out -> zig-zag order."""
    return transposed[:, _ZIGZAG_TRANSPOSED]


def scan_events(image, divisors, lay: Layout, xp):
    """Huffman events `(blocks in scan order, 64)` of an edge-padded uint8 image (see
    `scan_coefficients` and `block_events`)."""
    quantized, dc_difference = scan_coefficients(image, divisors, lay, xp)
    return block_events(_zigzag(quantized), dc_difference, lay.table_ids, xp)


@functools.lru_cache(maxsize=64)
def band_plan(height: int, width: int, factors: tuple, bands: int = 4):
    """Horizontal bands of whole MCU rows: `[(first pixel row, layout of the band)]`.

    Each band is laid out as an image of its own (all but the last have the same
    size, so they share one compiled program); only DC prediction runs across bands.
    """
    lay = layout(height, width, factors)
    mcu_rows = lay.mcus[0]
    mcu_height = 8 * max(c.factors[1] for c in lay.components) if lay.interleaved else 8
    per_band = -(-mcu_rows // bands)
    plan = []
    for first in range(0, mcu_rows, per_band):
        row = first * mcu_height
        rows = min((first + per_band) * mcu_height, height) - row
        plan.append((row, layout(rows, width, factors)))
    return plan


@functools.lru_cache(maxsize=64)
def compiled_band_events(lay: Layout):
    """Jitted programs for one band of layout `lay`: `(padded image, divisors, first
    row) -> (events in zig-zag order, first DCs, last DCs)` of the band's rows, DC
    predicted from 0 (`pack_bands` fixes that).

    The events are computed in `_fdct`'s coefficient order and put into zig-zag order
    by a second program. Measured on CPU, that split is the fastest arrangement: with a
    zig-zag gather inside the program, XLA lays the data out slots-first (blocks along
    the minor axis) and every kernel after the gather runs about twice as slow.
    """
    import jax
    import jax.numpy as jnp

    from gfxlab._xla_options import legacy_cpu_emitters

    def events(image, divisors, row):
        band = jax.lax.dynamic_slice_in_dim(image, row, lay.padded[0], axis=0)
        quantized, dc_difference = scan_coefficients(band, divisors, lay, jnp)
        coded = block_events(quantized, dc_difference, lay.table_ids, jnp, order="fdct")
        return (coded, *_edge_dcs(quantized, lay, jnp))

    options = legacy_cpu_emitters()  # faster integer kernels on CPU (see the module)
    events = jax.jit(events, compiler_options=options)
    zigzag = jax.jit(_zigzag, compiler_options=options)
    rows = {}  # band offsets kept on the device: a host scalar is transferred per call

    def run(image, divisors, row: int):
        if row not in rows:
            rows[row] = jax.device_put(np.int32(row))
        coded, first, last = events(image, divisors, rows[row])
        return zigzag(coded), first, last

    return run
