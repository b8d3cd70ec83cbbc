"""The JPEG pipeline one stage at a time, in floating point (JAX, differentiable).

These are the textbook stages used in the lab and by `compress`'s gradient path; the
bit-exact integer versions libjpeg uses live in `gfxlab.jpeg._libjpeg`. Samples are
on JPEG's 0..255 scale from `level_shift` on; colour conversion works on images in
[0, 1] (multiply by 255 for JFIF's 0..255 values).

Examples:
    The exam's Q5f block, given level-shifted in the answer key:

    >>> import numpy as np
    >>> shifted = np.array([
    ...     [-76, -73, -67, -62, -58, -67, -64, -55], [-65, -69, -73, -38, -19, -43, -59, -56],
    ...     [-66, -69, -60, -15, 16, -24, -62, -55], [-65, -70, -57, -6, 26, -22, -58, -59],
    ...     [-61, -67, -60, -24, -2, -40, -60, -58], [-49, -63, -68, -58, -51, -60, -70, -53],
    ...     [-43, -57, -64, -69, -73, -67, -63, -45], [-41, -49, -59, -60, -63, -52, -50, -34]])
    >>> coefs = dct2(level_shift(shifted + 128))
    >>> q = quantize(coefs, quant_tables(50)[0])    # quality 50: the standard luminance table
    >>> [int(v) for v in zigzag(q)[:6]]
    [-26, -3, 0, -3, -2, -6]
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gfxlab._checks import (
    check_allocation,
    check_finite,
    check_last_dim,
    check_range,
    finite_float,
    static_int,
    static_shape,
    value_error_if,
)
from gfxlab.jpeg._symbols import category, huffman_code_block, run_length
from gfxlab.jpeg._tables import (
    CHROMINANCE_TABLE,
    LUMINANCE_TABLE,
    SUBSAMPLING,
    ZIGZAG,
    ijg_scale,
    ijg_tables,
)

__all__ = [
    "rgb_to_ycbcr",
    "ycbcr_to_rgb",
    "subsample",
    "upsample",
    "blocks",
    "unblocks",
    "level_shift",
    "DCT_MATRIX",
    "dct2",
    "idct2",
    "quant_tables",
    "quant_tables_continuous",
    "quantize",
    "dequantize",
    "zigzag",
    "unzigzag",
    "category",
    "run_length",
    "huffman_code_block",
]

# JFIF (ITU-R BT.601 full range) colour matrix, rows Y, Cb, Cr.
_RGB_TO_YCC = np.array(
    [
        [0.299, 0.587, 0.114],
        [-0.168736, -0.331264, 0.5],
        [0.5, -0.418688, -0.081312],
    ]
)
_OFFSET = np.array([0.0, 128.0, 128.0]) / 255.0


def rgb_to_ycbcr(rgb: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """JFIF RGB -> YCbCr, images in [0, 1].

    `Y = 0.299 R + 0.587 G + 0.114 B`, `Cb = 128/255 + (B - Y) / 1.772`,
    `Cr = 128/255 + (R - Y) / 1.402` (times 255: JFIF's 0..255 values).

    **Arguments:**

    - `rgb`: `(..., 3)` float RGB.

    **Returns:**

    `(..., 3)` Y, Cb, Cr.
    """
    rgb = finite_float(rgb, "rgb")
    check_last_dim(rgb, "rgb", (3,), "RGB")
    m = jnp.asarray(_RGB_TO_YCC, rgb.dtype)
    return rgb @ m.T + jnp.asarray(_OFFSET, rgb.dtype)


def ycbcr_to_rgb(ycbcr: Float[Array, "*batch 3"]) -> Float[Array, "*batch 3"]:
    """Inverse of `rgb_to_ycbcr` (no clipping).

    **Arguments:**

    - `ycbcr`: `(..., 3)` float Y, Cb, Cr in [0, 1] units.

    **Returns:**

    `(..., 3)` RGB.
    """
    ycbcr = finite_float(ycbcr, "ycbcr")
    check_last_dim(ycbcr, "ycbcr", (3,), "Y, Cb, Cr")
    m = jnp.asarray(np.linalg.inv(_RGB_TO_YCC), ycbcr.dtype)
    return (ycbcr - jnp.asarray(_OFFSET, ycbcr.dtype)) @ m.T


def _factors(subsampling) -> tuple[int, int]:
    if subsampling not in SUBSAMPLING:
        raise ValueError(f"`subsampling` must be one of {sorted(SUBSAMPLING)}, got {subsampling!r}")
    return SUBSAMPLING[subsampling]


def _plane(x, name):
    x = finite_float(x, name)
    if x.ndim < 2 or x.shape[-2] < 1 or x.shape[-1] < 1:
        raise ValueError(
            f"`{name}` must have shape (..., H, W) with H, W >= 1, got shape {tuple(x.shape)}"
        )
    return x


def _pad_edge(x, rows, cols):
    r, c = x.shape[-2:]
    pad = [(0, 0)] * (x.ndim - 2) + [(0, rows - r), (0, cols - c)]
    return jnp.pad(x, pad, mode="edge")


def subsample(chroma: Float[Array, "*batch H W"], *, subsampling: str = "4:2:0") -> Array:
    """Chroma subsampling by averaging cells (edge pixels repeated for odd sizes).

    **Arguments:**

    - `chroma`: `(..., H, W)` a chroma plane.
    - `subsampling`: `"4:4:4"` (unchanged), `"4:2:2"` (2 x 1 cells), `"4:2:0"` (2 x 2).

    **Returns:**

    `(..., ceil(H / v), ceil(W / h))`.
    """
    x = _plane(chroma, "chroma")
    h, v = _factors(subsampling)
    rows, cols = x.shape[-2:]
    x = _pad_edge(x, -(-rows // v) * v, -(-cols // h) * h)
    x = x.reshape(*x.shape[:-2], x.shape[-2] // v, v, x.shape[-1] // h, h)
    return x.mean(axis=(-3, -1))


def upsample(
    chroma: Float[Array, "*batch h w"],
    shape: tuple[int, int],
    *,
    subsampling: str = "4:2:0",
    method: str = "fancy",
) -> Array:
    """Chroma upsampling back to `shape`.

    `method="fancy"` is libjpeg's triangular filter (each output sample is 3/4 of
    the nearest input and 1/4 of the next nearest, in each direction; in floating
    point here); `"nearest"` repeats samples.

    **Arguments:**

    - `chroma`: `(..., h, w)` subsampled plane, `h = ceil(H / v)`, `w = ceil(W / h)`
      (what `subsample` returns for `shape`).
    - `shape`: the full `(H, W)`.
    - `subsampling`: as in `subsample`.
    - `method`: `"fancy"` or `"nearest"`.

    **Returns:**

    `(..., H, W)`.
    """
    x = _plane(chroma, "chroma")
    rows, cols = static_shape(shape, "shape")
    h, v = _factors(subsampling)
    if method not in ("fancy", "nearest"):
        raise ValueError(f"`method` must be 'fancy' or 'nearest', got {method!r}")
    expected = (-(-rows // v), -(-cols // h))
    if tuple(x.shape[-2:]) != expected:
        raise ValueError(
            f"`chroma` must have shape (..., {expected[0]}, {expected[1]}) to upsample to "
            f"`shape` {(rows, cols)} with {subsampling}, got shape {tuple(x.shape)}"
        )
    if method == "nearest" or (h == 2 and x.shape[-1] <= 2):
        x = jnp.repeat(jnp.repeat(x, v, axis=-2), h, axis=-1)
    else:
        if v == 2:
            up = jnp.concatenate([x[..., :1, :], x[..., :-1, :]], axis=-2)
            down = jnp.concatenate([x[..., 1:, :], x[..., -1:, :]], axis=-2)
            x = jnp.stack([(3 * x + up) / 4, (3 * x + down) / 4], axis=-2)
            x = x.reshape(*x.shape[:-3], -1, x.shape[-1])
        if h == 2:
            left = jnp.concatenate([x[..., :1], x[..., :-1]], axis=-1)
            right = jnp.concatenate([x[..., 1:], x[..., -1:]], axis=-1)
            x = jnp.stack([(3 * x + left) / 4, (3 * x + right) / 4], axis=-1)
            x = x.reshape(*x.shape[:-2], -1)
    return _pad_edge(x, max(rows, x.shape[-2]), max(cols, x.shape[-1]))[..., :rows, :cols]


#: Largest block size `blocks` accepts (JPEG uses 8).
MAX_BLOCK_SIZE = 1024


def blocks(plane: Float[Array, "*batch H W"], *, size: int = 8) -> Array:
    """Cut a plane into `size x size` blocks, repeating edge pixels to fill the last.

    **Arguments:**

    - `plane`: `(..., H, W)`.
    - `size`: block size (8 in JPEG), at most `MAX_BLOCK_SIZE` (1024).

    **Returns:**

    `(..., ceil(H / size), ceil(W / size), size, size)`.
    """
    x = _plane(plane, "plane")
    size = static_int(size, "size", minimum=1, maximum=MAX_BLOCK_SIZE)
    rows, cols = x.shape[-2:]
    batch = int(np.prod(x.shape[:-2]))
    check_allocation(batch * -(-rows // size) * size * -(-cols // size) * size, "size")
    x = _pad_edge(x, -(-rows // size) * size, -(-cols // size) * size)
    r, c = x.shape[-2] // size, x.shape[-1] // size
    return jnp.swapaxes(x.reshape(*x.shape[:-2], r, size, c, size), -3, -2)


def unblocks(block_array: Float[Array, "*batch R C n n"], shape: tuple[int, int]) -> Array:
    """Inverse of `blocks`: reassemble and crop to `shape = (H, W)`.

    **Arguments:**

    - `block_array`: `(..., R, C, n, n)`.
    - `shape`: `(H, W)` with `H <= R n`, `W <= C n`.

    **Returns:**

    `(..., H, W)`.
    """
    x = finite_float(block_array, "block_array")
    if x.ndim < 4 or x.shape[-1] != x.shape[-2] or 0 in x.shape[-4:]:
        raise ValueError(f"`block_array` must have shape (..., R, C, n, n), got {x.shape}")
    rows, cols = static_shape(shape, "shape")
    r, c, n = x.shape[-4], x.shape[-3], x.shape[-1]
    if rows > r * n or cols > c * n:
        raise ValueError(f"`shape` {shape} is larger than the blocks cover ({r * n}, {c * n})")
    x = jnp.swapaxes(x, -3, -2).reshape(*x.shape[:-4], r * n, c * n)
    return x[..., :rows, :cols]


def level_shift(samples: Array, *, inverse: bool = False) -> Array:
    """JPEG's level shift of 8-bit samples: `x - 128` (or `x + 128` with `inverse`).

    **Arguments:**

    - `samples`: values on the 0..255 scale (any shape).
    - `inverse`: undo the shift.

    **Returns:**

    The shifted values (centred on 0: -128..127).
    """
    x = finite_float(samples, "samples")
    return x + 128.0 if inverse else x - 128.0


def _dct_matrix(n: int = 8) -> np.ndarray:
    k = np.arange(n)[:, None]
    x = np.arange(n)[None, :]
    alpha = np.where(k == 0, np.sqrt(1.0 / n), np.sqrt(2.0 / n))
    return alpha * np.cos(np.pi * (2 * x + 1) * k / (2 * n))


#: The orthonormal 8-point DCT-II matrix `C[u, x] = a(u) cos(pi (2x + 1) u / 16)`,
#: `a(0) = sqrt(1/8)`, `a(u) = sqrt(2/8)`: `dct2(g) = C @ g @ C.T`.
DCT_MATRIX = _dct_matrix()
DCT_MATRIX.setflags(write=False)


def _check_block(x, name):
    x = finite_float(x, name)
    if x.ndim < 2 or x.shape[-2:] != (8, 8):
        raise ValueError(f"`{name}` must have shape (..., 8, 8), got shape {tuple(x.shape)}")
    return x


def dct2(block: Float[Array, "*batch 8 8"]) -> Float[Array, "*batch 8 8"]:
    """Orthonormal 2-D DCT-II of 8 x 8 blocks (the exam's `G[u, v]` formula).

    **Arguments:**

    - `block`: `(..., 8, 8)` level-shifted samples `g[x, y]`.

    **Returns:**

    `(..., 8, 8)` coefficients; `[0, 0]` is the DC term (8 x the block mean).
    """
    x = _check_block(block, "block")
    c = jnp.asarray(DCT_MATRIX, x.dtype)
    return c @ x @ c.T


def idct2(coefficients: Float[Array, "*batch 8 8"]) -> Float[Array, "*batch 8 8"]:
    """Inverse of `dct2` (orthonormal DCT-III).

    **Arguments:**

    - `coefficients`: `(..., 8, 8)`.

    **Returns:**

    `(..., 8, 8)` samples.
    """
    x = _check_block(coefficients, "coefficients")
    c = jnp.asarray(DCT_MATRIX, x.dtype)
    return c.T @ x @ c


def quant_tables(quality: int = 50) -> tuple[Array, Array]:
    """IJG quality scaling of the Annex K tables, as libjpeg's `jpeg_set_quality`.

    `scale = 5000 // q` below 50, else `200 - 2 q`; each entry becomes
    `(base * scale + 50) // 100` clamped to 1..255 (baseline). Quality 50 gives the
    Annex K tables themselves.

    **Arguments:**

    - `quality`: int in 1..100.

    **Returns:**

    `(luminance, chrominance)`, two `(8, 8)` int32 arrays (natural order).
    """
    quality = static_int(quality, "quality", minimum=1)
    if quality > 100:
        raise ValueError(f"`quality` must be in 1..100, got {quality}")
    return tuple(jnp.asarray(t) for t in ijg_tables(quality, np))


_SCALES = np.array([ijg_scale(q) for q in range(1, 101)], float)


def quant_tables_continuous(quality) -> tuple[Array, Array]:
    """`quant_tables` for a real, differentiable quality in [1, 100].

    IJG's integer scale factor (`5000 // q` or `200 - 2 q`) is interpolated linearly
    between integer qualities, and the entries are `base * scale / 100` clipped to
    [1, 255] without the final integer rounding: within 0.5 of `quant_tables` at
    integer qualities. Finite gradients on all of [1, 100].

    **Arguments:**

    - `quality`: scalar in [1, 100], may be traced (outside: a `ValueError`, eagerly
      and under `jax.jit`).

    **Returns:**

    `(luminance, chrominance)` float `(8, 8)` tables.
    """
    q = finite_float(quality, "quality")
    if q.ndim != 0:
        raise ValueError(f"`quality` must be a scalar, got shape {q.shape}")
    q = check_range(q, "quality", minimum=1.0, maximum=100.0)
    scales = jnp.asarray(_SCALES, q.dtype)
    low = jnp.clip(jnp.floor(q), 1, 99)
    frac = q - low
    i = jax.lax.stop_gradient(low).astype(jnp.int32) - 1
    scale = scales[i] * (1 - frac) + scales[i + 1] * frac
    return tuple(
        jnp.clip(jnp.asarray(t, q.dtype) * scale / 100.0, 1.0, 255.0)
        for t in (LUMINANCE_TABLE, CHROMINANCE_TABLE)
    )


def _positive_table(table):
    t = _check_block(table, "table")
    return value_error_if(t, t <= 0, "`table` must hold positive quantizer steps (no zero)")


def _round_half_away(x):
    return jnp.sign(x) * jnp.floor(jnp.abs(x) + 0.5)


def quantize(coefficients: Array, table: Array, *, rounding: str = "nearest") -> Array:
    """`round(coefficients / table)`, half away from zero (as JPEG encoders do).

    **Arguments:**

    - `coefficients`: `(..., 8, 8)` DCT coefficients.
    - `table`: `(8, 8)` quantization table (positive).
    - `rounding`: `"nearest"` (plain rounding, zero gradient), `"ste"` (straight-
      through: gradient of the identity), `"deadzone"` (straight-through for the
      coefficients, but w.r.t. the table a coefficient rounded to zero counts a
      quarter: it stays zero as the step grows, which straight-through ignores, and
      so overstates d/d(step) 2-4x) or `"cubic"` (soft rounding `r + (x - r)**3`,
      `r = round(x)`).

    **Returns:**

    The quantized coefficients (float, integral values for `"nearest"`/`"ste"`).
    """
    x = _check_block(coefficients, "coefficients")
    t = _positive_table(table)
    y = x / t
    r = jax.lax.stop_gradient(_round_half_away(y))
    if rounding == "nearest":
        return r
    if rounding == "ste":
        return y + jax.lax.stop_gradient(r - y)
    if rounding == "deadzone":
        # value r; d/dx as straight-through; d(q * t)/dt = w (r - y), w = 1/4 at r = 0.
        w = jnp.where(r == 0, 0.25, 1.0)
        c = jax.lax.stop_gradient((w - 1) * (r - y) / t)
        return r + (y - jax.lax.stop_gradient(y)) + c * (t - jax.lax.stop_gradient(t))
    if rounding == "cubic":
        return r + (y - r) ** 3
    raise ValueError(
        f"`rounding` must be 'nearest', 'ste', 'deadzone' or 'cubic', got {rounding!r}"
    )


def dequantize(quantized: Array, table: Array) -> Array:
    """`quantized * table`: the decoder's coefficient estimate.

    **Arguments:**

    - `quantized`: `(..., 8, 8)`.
    - `table`: `(8, 8)`.

    **Returns:**

    `(..., 8, 8)` float.
    """
    return _check_block(quantized, "quantized") * _check_block(table, "table")


def _array(x, name):
    """`x` as a JAX array of numbers (ints stay ints), finite if float."""
    if x is None:
        raise TypeError(f"`{name}` must be an array of numbers, got None")
    try:
        arr = jnp.asarray(x)
    except TypeError as err:
        raise TypeError(f"`{name}` must be array-like of numbers, got {type(x).__name__}") from err
    if jnp.issubdtype(arr.dtype, jnp.inexact):
        arr = check_finite(arr, name)
    return arr


def zigzag(block: Array) -> Array:
    """Read 8 x 8 blocks in zig-zag order (low to high frequency).

    **Arguments:**

    - `block`: `(..., 8, 8)`.

    **Returns:**

    `(..., 64)`: `block.reshape(..., 64)[..., ZIGZAG]`.
    """
    x = _array(block, "block")
    if x.ndim < 2 or x.shape[-2:] != (8, 8):
        raise ValueError(f"`block` must have shape (..., 8, 8), got shape {tuple(x.shape)}")
    return x.reshape(*x.shape[:-2], 64)[..., ZIGZAG]


def unzigzag(sequence: Array) -> Array:
    """Inverse of `zigzag`.

    **Arguments:**

    - `sequence`: `(..., 64)`.

    **Returns:**

    `(..., 8, 8)`.
    """
    x = _array(sequence, "sequence")
    if x.ndim < 1 or x.shape[-1] != 64:
        raise ValueError(f"`sequence` must have shape (..., 64), got shape {tuple(x.shape)}")
    return x[..., np.argsort(ZIGZAG)].reshape(*x.shape[:-1], 8, 8)
