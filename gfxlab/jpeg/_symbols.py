"""The symbol stages of the textbook JPEG pipeline, after zig-zag: the magnitude
category of a value, the run-length pairs of a block's AC coefficients, and the
Huffman code of one block with the Annex K tables, symbol by symbol.

Plain Python on integers (these are the stages a student traces by hand); the
vectorized entropy coder of real files is `gfxlab.jpeg._entropy`/`_encoder`. The
public names are re-exported by `gfxlab.jpeg.stages` and `gfxlab.jpeg`.
"""

from __future__ import annotations

import jax
import numpy as np

from gfxlab.jpeg._tables import (
    AC_CHROMINANCE,
    AC_LUMINANCE,
    DC_CHROMINANCE,
    DC_LUMINANCE,
    huffman_codes,
)

__all__ = ["category", "run_length", "huffman_code_block"]


def _integer(value, name: str) -> int:
    if isinstance(value, bool) or value is None:
        raise TypeError(f"`{name}` must be an integer, got {value!r}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be an integer, got {value!r}") from None
    if not np.isfinite(number) or number != int(number):
        raise ValueError(f"`{name}` must be an integer, got {value!r}")
    return int(number)


def category(value: int) -> int:
    """JPEG magnitude category (SSSS): the bit length of `|value|`, for an integer
    `value` in -32767..32767 (16-bit coefficients and differences: categories 0..15)."""
    number = _integer(value, "value")
    if abs(number) > 32767:
        raise ValueError(f"`value` must be in -32767..32767 (categories 0..15), got {number}")
    return abs(number).bit_length()


def _integers(x, name: str, size: int) -> np.ndarray:
    """`x` as a NumPy int64 vector of `size` integral values."""
    if x is None:
        raise TypeError(f"`{name}` must be an array of integers, got None")
    arr = np.asarray(jax.device_get(x) if isinstance(x, jax.Array) else x)
    if arr.shape != (size,):
        raise ValueError(f"`{name}` must have shape ({size},), got shape {arr.shape}")
    if not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise TypeError(f"`{name}` must hold numbers, got dtype {arr.dtype}")
    if not np.all(np.isfinite(arr)) or not np.all(arr == np.round(arr)):
        raise ValueError(f"`{name}` must hold finite integers (quantized coefficients)")
    return arr.astype(np.int64)


def run_length(ac) -> list[tuple[int, int]]:
    """Run-length code the 63 AC coefficients of one zig-zagged block.

    Each nonzero AC value becomes `(run, value)`: `run` zeros precede it. Runs of 16
    zeros followed by more nonzeros become `(15, 0)` (ZRL); trailing zeros become
    `(0, 0)` (EOB), omitted when the last coefficient is nonzero.

    **Arguments:**

    - `ac`: 63 integers (zig-zag positions 1..63).

    **Returns:**

    List of `(run, value)` pairs.
    """
    ac = _integers(ac, "ac", 63)
    out: list[tuple[int, int]] = []
    run = 0
    for v in ac.astype(np.int64).tolist():
        if v == 0:
            run += 1
            continue
        while run > 15:
            out.append((15, 0))
            run -= 16
        out.append((run, v))
        run = 0
    if run:
        out.append((0, 0))
    return out


def _bits(value: int, length: int) -> str:
    return format(value, f"0{length}b") if length else ""


def huffman_code_block(
    coefficients, *, previous_dc: int = 0, chroma: bool = False
) -> list[tuple[str, str, str]]:
    """Huffman-code one zig-zagged block with the Annex K tables, symbol by symbol.

    **Arguments:**

    - `coefficients`: 64 quantized coefficients in zig-zag order.
    - `previous_dc`: the DC value of the previous block of the component (DC is
      coded as a difference).
    - `chroma`: use the chrominance tables.

    **Returns:**

    One `(symbol, huffman_bits, extra_bits)` string triple per coded symbol, e.g.
    `("DC diff -26", "11100", "00101")`; concatenating the bit strings gives the
    block's bit stream.
    """
    zz = _integers(coefficients, "coefficients", 64)
    diff = int(zz[0]) - _integer(previous_dc, "previous_dc")
    if abs(diff) > 2047:
        raise ValueError(
            f"the DC difference `coefficients[0] - previous_dc` = {diff} is outside "
            "-2047..2047 (baseline categories 0..11)"
        )
    if np.abs(zz[1:]).max() > 1023:
        raise ValueError("AC `coefficients` must lie in -1023..1023 (baseline categories 1..10)")
    dc_codes = huffman_codes(DC_CHROMINANCE if chroma else DC_LUMINANCE)
    ac_codes = huffman_codes(AC_CHROMINANCE if chroma else AC_LUMINANCE)
    out = []
    size = category(diff)
    code, length = dc_codes[size]
    extra = diff if diff >= 0 else diff + (1 << size) - 1
    out.append((f"DC diff {diff}", _bits(code, length), _bits(extra, size)))
    for run, v in run_length(zz[1:]):
        size = category(v)
        code, length = ac_codes[run << 4 | size]
        extra = v if v >= 0 else v + (1 << size) - 1
        name = "EOB" if (run, v) == (0, 0) else "ZRL" if (run, v) == (15, 0) else f"({run},{v})"
        out.append((name, _bits(code, length), _bits(extra, size)))
    return out
