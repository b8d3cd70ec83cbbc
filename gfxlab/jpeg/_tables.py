"""Constants of baseline JPEG: ITU-T T.81 Annex K tables and the zig-zag order."""

from __future__ import annotations

import numpy as np

#: Annex K.1, Table K.1: luminance quantization table (natural row-major order).
LUMINANCE_TABLE = np.array(
    [
        [16, 11, 10, 16, 24, 40, 51, 61],
        [12, 12, 14, 19, 26, 58, 60, 55],
        [14, 13, 16, 24, 40, 57, 69, 56],
        [14, 17, 22, 29, 51, 87, 80, 62],
        [18, 22, 37, 56, 68, 109, 103, 77],
        [24, 35, 55, 64, 81, 104, 113, 92],
        [49, 64, 78, 87, 103, 121, 120, 101],
        [72, 92, 95, 98, 112, 100, 103, 99],
    ],
    dtype=np.int32,
)
LUMINANCE_TABLE.setflags(write=False)

#: Annex K.1, Table K.2: chrominance quantization table (natural row-major order).
CHROMINANCE_TABLE = np.full((8, 8), 99, dtype=np.int32)
CHROMINANCE_TABLE[:4, :4] = [
    [17, 18, 24, 47],
    [18, 21, 26, 66],
    [24, 26, 56, 99],
    [47, 66, 99, 99],
]
CHROMINANCE_TABLE.setflags(write=False)


def _zigzag_order() -> np.ndarray:
    # Walk the anti-diagonals r + c = s; odd diagonals run down-left (row increasing),
    # even ones up-right (row decreasing).
    cells = [(r, c) for r in range(8) for c in range(8)]
    cells.sort(key=lambda rc: (rc[0] + rc[1], rc[0] if (rc[0] + rc[1]) % 2 else rc[1]))
    order = np.array([8 * r + c for r, c in cells], dtype=np.int32)
    order.setflags(write=False)
    return order


#: `ZIGZAG[k]` is the row-major index (`8 * row + col`) of the k-th coefficient in
#: zig-zag order.
ZIGZAG = _zigzag_order()

# Annex K.3: the typical Huffman tables, as (BITS, HUFFVAL): BITS[l - 1] codes of
# length l, HUFFVAL the symbols in order of increasing code length.
DC_LUMINANCE = (
    (0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0),
    tuple(range(12)),
)
DC_CHROMINANCE = (
    (0, 3, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0),
    tuple(range(12)),
)
AC_LUMINANCE = (
    (0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7D),
    tuple(
        bytes.fromhex(
            "01020300041105122131410613516107227114328191a1082342b1c11552d1f0"
            "2433627282090a161718191a25262728292a3435363738393a43444546474849"
            "4a535455565758595a636465666768696a737475767778797a83848586878889"
            "8a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4b5b6b7b8b9bac2c3c4c5"
            "c6c7c8c9cad2d3d4d5d6d7d8d9dae1e2e3e4e5e6e7e8e9eaf1f2f3f4f5f6f7f8"
            "f9fa"
        )
    ),
)
AC_CHROMINANCE = (
    (0, 2, 1, 2, 4, 4, 3, 4, 7, 5, 4, 4, 0, 1, 2, 0x77),
    tuple(
        bytes.fromhex(
            "000102031104052131061241510761711322328108144291a1b1c109233352f0"
            "156272d10a162434e125f11718191a262728292a35363738393a434445464748"
            "494a535455565758595a636465666768696a737475767778797a828384858687"
            "88898a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4b5b6b7b8b9bac2c3"
            "c4c5c6c7c8c9cad2d3d4d5d6d7d8d9dae2e3e4e5e6e7e8e9eaf2f3f4f5f6f7f8"
            "f9fa"
        )
    ),
)

#: Chroma sampling name -> (horizontal, vertical) sampling factors of the luma
#: component (the chroma components are always 1 x 1).
SUBSAMPLING = {"4:4:4": (1, 1), "4:2:2": (2, 1), "4:2:0": (2, 2)}


def huffman_codes(spec) -> dict[int, tuple[int, int]]:
    """Canonical Huffman codes (Annex C) of a `(BITS, HUFFVAL)` table spec.

    **Arguments:**

    - `spec`: `(BITS, HUFFVAL)` as in a DHT segment.

    **Returns:**

    `{symbol: (code, length)}`. Raises `ValueError` if the lengths oversubscribe
    the code space.
    """
    try:
        bits, values = (tuple(int(v) for v in part) for part in spec)
    except (TypeError, ValueError):
        raise TypeError(
            f"`spec` must be a (BITS, HUFFVAL) pair of integer sequences, got {spec!r}"
        ) from None
    if len(bits) != 16 or min(bits + values, default=0) < 0 or max(values, default=0) > 255:
        raise ValueError("`spec` must hold 16 code counts (BITS) and byte symbols (HUFFVAL)")
    codes: dict[int, tuple[int, int]] = {}
    code = 0
    k = 0
    for length, count in enumerate(bits, start=1):
        for _ in range(count):
            if k >= len(values):
                raise ValueError("Huffman table lists more codes than symbols")
            codes[values[k]] = (code, length)
            code += 1
            k += 1
        if code >= (1 << length) and count:
            raise ValueError("Huffman code lengths oversubscribe the code space")
        code <<= 1
    return codes


def ijg_scale(quality, xp=np):
    """IJG's quality -> table scale in percent (`jpeg_quality_scaling`): `5000 // q`
    below 50, else `200 - 2 q`. `quality` is an int (or an int array, NumPy or JAX:
    `xp` is `numpy` or `jax.numpy`), already clipped to 1..100.

    This is the one place the scale curve lives: `quant_tables`, `encode`,
    `compress` and `quant_tables_continuous` all use it.
    """
    if xp is np and isinstance(quality, int | np.integer):
        return 5000 // quality if quality < 50 else 200 - 2 * quality
    return xp.where(quality < 50, 5000 // xp.maximum(quality, 1), 200 - 2 * quality)


def ijg_tables(quality, xp=np):
    """libjpeg's `jpeg_set_quality(quality, force_baseline=TRUE)`: the Annex K tables
    scaled by `ijg_scale(quality)`, `(base * scale + 50) // 100` clamped to 1..255.

    **Returns:** `(luminance, chrominance)` int32 `(8, 8)` arrays of module `xp`.
    """
    scale = ijg_scale(quality, xp)
    return tuple(
        xp.clip((xp.asarray(base, np.int32) * scale + 50) // 100, 1, 255).astype(np.int32)
        for base in (LUMINANCE_TABLE, CHROMINANCE_TABLE)
    )
