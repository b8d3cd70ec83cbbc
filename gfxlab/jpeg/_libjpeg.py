"""Bit-exact emulation of libjpeg-turbo's 8-bit baseline arithmetic.

Every function takes `xp` (`numpy` or `jax.numpy`) so that the byte encoder and
decoder (NumPy) and the differentiable round trip (`jax.numpy`, jittable) share one
implementation. What is emulated, stage by stage:

- colour conversion with 16-bit fixed-point tables (jccolor.c / jdcolor.c);
- h2v1 / h2v2 downsampling with libjpeg's alternating rounding bias (jcsample.c) and
  the edge replication of jcprepct.c;
- the "islow" integer DCT and inverse DCT (jfdctint.c / jidctint.c, CONST_BITS = 13,
  PASS1_BITS = 2), written as integer matrices: each pass is an exact integer linear
  map followed by one rounding right shift, so a matrix product reproduces it;
- libjpeg-turbo's quantization by reciprocal multiplication (jcdctmgr.c);
- "fancy" triangular upsampling (jdsample.c) and the IDCT range limit (jdmaster.c).
"""

from __future__ import annotations

import numpy as np

CONST_BITS = 13
PASS1_BITS = 2
SCALEBITS = 16
ONE_HALF = 1 << (SCALEBITS - 1)


def fix(x: float, bits: int = SCALEBITS) -> int:
    """libjpeg's `FIX(x)`: `x` in fixed point with `bits` fraction bits."""
    return int(x * (1 << bits) + 0.5)


def _is_numpy(xp) -> bool:
    return xp is np


def _int(xp):
    return np.int64 if _is_numpy(xp) else np.int32


# --- integer DCT matrices ---------------------------------------------------------


def _fdct_1d(d):
    """jfdctint.c's 1-D butterfly without its final descale; rows 0 and 4 are scaled
    by 2**13 so that every output is descaled the same way."""
    c = {k: fix(v, CONST_BITS) for k, v in _DCT_CONSTANTS.items()}
    tmp0, tmp7 = d[0] + d[7], d[0] - d[7]
    tmp1, tmp6 = d[1] + d[6], d[1] - d[6]
    tmp2, tmp5 = d[2] + d[5], d[2] - d[5]
    tmp3, tmp4 = d[3] + d[4], d[3] - d[4]
    tmp10, tmp13 = tmp0 + tmp3, tmp0 - tmp3
    tmp11, tmp12 = tmp1 + tmp2, tmp1 - tmp2
    out = [None] * 8
    out[0] = (tmp10 + tmp11) * (1 << 13)
    out[4] = (tmp10 - tmp11) * (1 << 13)
    z1 = (tmp12 + tmp13) * c["0_541196100"]
    out[2] = z1 + tmp13 * c["0_765366865"]
    out[6] = z1 - tmp12 * c["1_847759065"]
    z1, z2, z3, z4 = tmp4 + tmp7, tmp5 + tmp6, tmp4 + tmp6, tmp5 + tmp7
    z5 = (z3 + z4) * c["1_175875602"]
    tmp4 = tmp4 * c["0_298631336"]
    tmp5 = tmp5 * c["2_053119869"]
    tmp6 = tmp6 * c["3_072711026"]
    tmp7 = tmp7 * c["1_501321110"]
    z1 = z1 * -c["0_899976223"]
    z2 = z2 * -c["2_562915447"]
    z3 = z3 * -c["1_961570560"] + z5
    z4 = z4 * -c["0_390180644"] + z5
    out[7] = tmp4 + z1 + z3
    out[5] = tmp5 + z2 + z4
    out[3] = tmp6 + z2 + z3
    out[1] = tmp7 + z1 + z4
    return out


def _idct_1d(x):
    """jidctint.c's 1-D butterfly (input already dequantized) without the descale."""
    c = {k: fix(v, CONST_BITS) for k, v in _DCT_CONSTANTS.items()}
    z1 = (x[2] + x[6]) * c["0_541196100"]
    tmp2 = z1 - x[6] * c["1_847759065"]
    tmp3 = z1 + x[2] * c["0_765366865"]
    tmp0 = (x[0] + x[4]) * (1 << CONST_BITS)
    tmp1 = (x[0] - x[4]) * (1 << CONST_BITS)
    tmp10, tmp13 = tmp0 + tmp3, tmp0 - tmp3
    tmp11, tmp12 = tmp1 + tmp2, tmp1 - tmp2
    t0, t1, t2, t3 = x[7], x[5], x[3], x[1]
    z1, z2, z3, z4 = t0 + t3, t1 + t2, t0 + t2, t1 + t3
    z5 = (z3 + z4) * c["1_175875602"]
    t0 = t0 * c["0_298631336"]
    t1 = t1 * c["2_053119869"]
    t2 = t2 * c["3_072711026"]
    t3 = t3 * c["1_501321110"]
    z1 = z1 * -c["0_899976223"]
    z2 = z2 * -c["2_562915447"]
    z3 = z3 * -c["1_961570560"] + z5
    z4 = z4 * -c["0_390180644"] + z5
    t0, t1, t2, t3 = t0 + z1 + z3, t1 + z2 + z4, t2 + z2 + z3, t3 + z1 + z4
    return [
        tmp10 + t3,
        tmp11 + t2,
        tmp12 + t1,
        tmp13 + t0,
        tmp13 - t0,
        tmp12 - t1,
        tmp11 - t2,
        tmp10 - t3,
    ]


_DCT_CONSTANTS = {
    "0_298631336": 0.298631336,
    "0_390180644": 0.390180644,
    "0_541196100": 0.541196100,
    "0_765366865": 0.765366865,
    "0_899976223": 0.899976223,
    "1_175875602": 1.175875602,
    "1_501321110": 1.501321110,
    "1_847759065": 1.847759065,
    "1_961570560": 1.961570560,
    "2_053119869": 2.053119869,
    "2_562915447": 2.562915447,
    "3_072711026": 3.072711026,
}


def _matrix(butterfly) -> np.ndarray:
    eye = np.eye(8, dtype=np.int64)
    return np.stack([np.asarray(v) for v in butterfly(list(eye))])  # [out, in]


FDCT_MATRIX = _matrix(_fdct_1d)
IDCT_MATRIX = _matrix(_idct_1d)


def _descale(p, n: int, xp):
    return xp.right_shift(p + (1 << (n - 1)), n)


def _right_multiply(x, m, xp):
    """`x @ m` for a stack `(..., 8, 8)` and an integer matrix `m`, exactly: int64 in
    NumPy (no BLAS: its threads only get in the way for 8-wide products), wrapping int32
    in JAX (the 32-bit arithmetic libjpeg itself uses)."""
    if _is_numpy(xp):
        flat = np.asarray(x, np.int64).reshape(-1, 8)
        return (flat @ m.astype(np.int64)).reshape(x.shape)
    return xp.matmul(x.astype(np.int32), xp.asarray(m, np.int32))


def _left_multiply(m, x, xp):
    """`m @ x` for a stack `(..., 8, 8)`."""
    return xp.swapaxes(_right_multiply(xp.swapaxes(x, -1, -2), m.T, xp), -1, -2)


def fdct_islow(blocks, xp):
    """jfdctint.c on level-shifted samples `(..., 8, 8)`; output scaled by 8."""
    m = FDCT_MATRIX
    rows = _descale(_right_multiply(blocks, m.T, xp), CONST_BITS - PASS1_BITS, xp)
    out = _descale(_left_multiply(m, rows, xp), CONST_BITS + PASS1_BITS, xp)
    return out.astype(np.int64) if _is_numpy(xp) else out.astype(np.int32)


def idct_islow(coefficients, table, xp):
    """jidctint.c: dequantize, inverse DCT, range-limit; returns samples 0..255."""
    deq = (coefficients * xp.asarray(table).astype(coefficients.dtype)).astype(_int(xp))
    # The butterflies on whole rows / columns of the block stack (the same integer
    # expression as `IDCT_MATRIX`, wrapping alike in 32 bits; elementwise, which XLA
    # runs several times faster than an integer matrix product).
    cols = xp.stack(_idct_1d([deq[..., i, :] for i in range(8)]), axis=-2)
    cols = _descale(cols, CONST_BITS - PASS1_BITS, xp)
    out = xp.stack(_idct_1d([cols[..., j] for j in range(8)]), axis=-1)
    return _range_limit(out, xp)


def idct_islow_planar(coefficients, table, xp):
    """`idct_islow` for blocks laid out `(8, 8, ...)` (the blocks along the trailing,
    contiguous axes: every butterfly step is one long elementwise operation)."""
    table = xp.asarray(table).astype(coefficients.dtype)
    deq = (coefficients * table.reshape(8, 8, *([1] * (coefficients.ndim - 2)))).astype(_int(xp))
    cols = xp.stack(_idct_1d([deq[i] for i in range(8)]), axis=0)
    cols = _descale(cols, CONST_BITS - PASS1_BITS, xp)
    out = xp.stack(_idct_1d([cols[:, j] for j in range(8)]), axis=1)
    return _range_limit(out, xp)


def _range_limit(out, xp):
    """jidctint.c's final descale and range limit of the second pass's output."""
    out = _descale(out, CONST_BITS + PASS1_BITS + 3, xp).astype(_int(xp))
    # libjpeg indexes its range-limit table with `x & 1023`: wraps far outliers.
    wrapped = xp.bitwise_and(out, 1023)
    wrapped = xp.where(wrapped >= 512, wrapped - 1024, wrapped)
    return xp.clip(wrapped + 128, 0, 255)


def reciprocals(table) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """libjpeg-turbo's `compute_reciprocal` for the islow divisors `8 * table`
    (16-bit DCTELEM build): (reciprocal, correction, shift)."""
    divisor = np.asarray(table, np.int64).reshape(-1) * 8
    recip = np.empty_like(divisor)
    corr = np.empty_like(divisor)
    shift = np.empty_like(divisor)
    for i, d in enumerate(divisor.tolist()):
        r = 16 + d.bit_length() - 1
        fq, fr = divmod(1 << r, d)
        c = d // 2
        if fr == 0:
            fq >>= 1
            r -= 1
        elif fr <= d // 2:
            c += 1
        else:
            fq += 1
        recip[i], corr[i], shift[i] = fq, c, r
    shape = np.shape(table)
    return recip.reshape(shape), corr.reshape(shape), shift.reshape(shape)


def quantize_islow(coefficients, table, xp):
    """jcdctmgr.c's quantization of `fdct_islow` output with table `(8, 8)`."""
    table = np.asarray(table)
    recip, corr, shift = reciprocals(table)
    if _is_numpy(xp):
        mag = np.abs(coefficients)
        q = ((mag + corr) * recip) >> shift
        return np.where(coefficients < 0, -q, q)
    mag = xp.abs(coefficients).astype(np.uint32)
    q = ((mag + corr.astype(np.uint32)) * recip.astype(np.uint32)) >> shift.astype(np.uint32)
    q = q.astype(np.int32)
    return xp.where(coefficients < 0, -q, q)


def quantize_islow_traced(coefficients, table, xp):
    """`quantize_islow` for a traced (JAX) table: the reciprocal is computed in-graph."""
    divisor = table.astype(np.uint32) * 8
    b = (31 - xp.asarray(lax_clz(divisor, xp))).astype(np.uint32)
    r = 16 + b
    one = xp.left_shift(xp.ones_like(divisor), r)
    fq = one // divisor
    fr = one % divisor
    c = divisor // 2
    pow2 = fr == 0
    fq = xp.where(pow2, fq >> 1, xp.where(fr > divisor // 2, fq + 1, fq))
    r = xp.where(pow2, r - 1, r)
    c = xp.where(~pow2 & (fr <= divisor // 2), c + 1, c)
    mag = xp.abs(coefficients).astype(np.uint32)
    q = (((mag + c) * fq) >> r).astype(np.int32)
    return xp.where(coefficients < 0, -q, q)


def lax_clz(x, xp):
    import jax.lax as lax

    return lax.clz(x)


# --- colour ---------------------------------------------------------------------


def rgb_to_ycc(rgb, xp):
    """jccolor.c: uint8 RGB `(..., 3)` -> integer Y, Cb, Cr planes."""
    rgb = rgb.astype(_int(xp))
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    offset = (128 << SCALEBITS) + ONE_HALF - 1
    y = (fix(0.299) * r + fix(0.587) * g + fix(0.114) * b + ONE_HALF) >> SCALEBITS
    cb = (-fix(0.16874) * r - fix(0.33126) * g + fix(0.5) * b + offset) >> SCALEBITS
    cr = (fix(0.5) * r - fix(0.41869) * g - fix(0.08131) * b + offset) >> SCALEBITS
    return y, cb, cr


def ycc_to_rgb(y, cb, cr, xp):
    """jdcolor.c: integer Y, Cb, Cr planes -> uint8 RGB `(..., 3)`."""
    y, cb, cr = (v.astype(_int(xp)) - (0 if i == 0 else 128) for i, v in enumerate((y, cb, cr)))
    r = y + ((fix(1.402) * cr + ONE_HALF) >> SCALEBITS)
    g = y + ((-fix(0.34414) * cb + ONE_HALF - fix(0.71414) * cr) >> SCALEBITS)
    b = y + ((fix(1.772) * cb + ONE_HALF) >> SCALEBITS)
    return xp.clip(xp.stack([r, g, b], axis=-1), 0, 255).astype(np.uint8)


# --- sampling -------------------------------------------------------------------


def downsample(plane, h: int, v: int, xp):
    """jcsample.c: average `v x h` cells (h, v in {1, 2}) with the alternating bias;
    `plane` must already be padded to multiples of the cell."""
    plane = plane.astype(_int(xp))
    rows, cols = plane.shape[-2:]
    if v == 2:
        plane = plane[..., 0::2, :] + plane[..., 1::2, :]
    if h == 2:
        plane = plane[..., :, 0::2] + plane[..., :, 1::2]
    if h == 1 and v == 1:
        return plane
    parity = xp.arange(plane.shape[-1]) % 2
    if h == 2 and v == 2:
        return (plane + 1 + parity) >> 2
    if h == 2:
        return (plane + parity) >> 1
    return (plane + 1) >> 1  # int_downsample rounding (h1v2)


def upsample_fancy(plane, h: int, v: int, xp):
    """jdsample.c's triangular ("fancy") upsampling by (h, v) in {1, 2}; plane is the
    component's real (downsampled) size. Falls back to replication like libjpeg when
    the plane is at most 2 samples wide."""
    plane = plane.astype(_int(xp))
    if h == 1 and v == 1:
        return plane
    if plane.shape[-1] <= 2 and h == 2:
        return xp.repeat(xp.repeat(plane, h, axis=-1), v, axis=-2)
    if v == 2:
        up = xp.concatenate([plane[..., :1, :], plane[..., :-1, :]], axis=-2)
        down = xp.concatenate([plane[..., 1:, :], plane[..., -1:, :]], axis=-2)
        near, far_up, far_down = 3 * plane, up, down
        if h == 1:
            top = (near + far_up + 1) >> 2
            bottom = (near + far_down + 2) >> 2
            return xp.stack([top, bottom], axis=-2).reshape(*plane.shape[:-2], -1, plane.shape[-1])
        sums = xp.stack([near + far_up, near + far_down], axis=-2)  # (..., R, 2, C)
        sums = sums.reshape(*plane.shape[:-2], -1, plane.shape[-1])
        left = xp.concatenate([sums[..., :1], sums[..., :-1]], axis=-1)
        right = xp.concatenate([sums[..., 1:], sums[..., -1:]], axis=-1)
        even = (3 * sums + left + 8) >> 4
        odd = (3 * sums + right + 7) >> 4
        return xp.stack([even, odd], axis=-1).reshape(*sums.shape[:-1], -1)
    left = xp.concatenate([plane[..., :1], plane[..., :-1]], axis=-1)
    right = xp.concatenate([plane[..., 1:], plane[..., -1:]], axis=-1)
    even = (3 * plane + left + 1) >> 2
    odd = (3 * plane + right + 2) >> 2
    return xp.stack([even, odd], axis=-1).reshape(*plane.shape[:-1], -1)


def pad_edge(plane, rows: int, cols: int, xp):
    """Replicate the last row / column of `(..., R, C)` up to `(rows, cols)`."""
    r, c = plane.shape[-2:]
    if rows > r:
        plane = xp.concatenate([plane, xp.repeat(plane[..., -1:, :], rows - r, axis=-2)], axis=-2)
    if cols > c:
        plane = xp.concatenate([plane, xp.repeat(plane[..., -1:], cols - c, axis=-1)], axis=-1)
    return plane[..., :rows, :cols]


def to_blocks(plane, xp):
    """`(..., 8R, 8C)` -> `(..., R, C, 8, 8)`."""
    r, c = plane.shape[-2] // 8, plane.shape[-1] // 8
    x = plane.reshape(*plane.shape[:-2], r, 8, c, 8)
    return xp.swapaxes(x, -3, -2)


def from_blocks(blocks, xp):
    """`(..., R, C, 8, 8)` -> `(..., 8R, 8C)`."""
    r, c = blocks.shape[-4], blocks.shape[-3]
    return xp.swapaxes(blocks, -3, -2).reshape(*blocks.shape[:-4], 8 * r, 8 * c)


# --- the whole pipeline ---------------------------------------------------------


def component_layout(height: int, width: int, factors):
    """Per component: sampling (h, v), real size, size in blocks (libjpeg's
    `jdiv_round_up` rules). `factors` lists (h, v) per component."""
    hmax = max(f[0] for f in factors)
    vmax = max(f[1] for f in factors)
    layout = []
    for h, v in factors:
        w_c = -(-width * h // hmax)
        h_c = -(-height * v // vmax)
        layout.append(((h, v), (h_c, w_c), (-(-h_c // 8), -(-w_c // 8))))
    return hmax, vmax, layout


def forward(planes, factors, tables, xp, *, traced_tables: bool = False):
    """Colour planes -> quantized coefficient blocks per component, as libjpeg.

    **Arguments:**

    - `planes`: integer sample planes `(H, W)` (Y, Cb, Cr or just grey).
    - `factors`: `(h, v)` sampling factors per component.
    - `tables`: quantization table `(8, 8)` per component.

    **Returns:**

    List of `(rows_in_blocks, cols_in_blocks, 8, 8)` integer coefficient arrays in
    natural order (only the real blocks, not the MCU padding).
    """
    height, width = planes[0].shape
    hmax, vmax, layout = component_layout(height, width, factors)
    out = []
    for plane, table, ((h, v), _, (bh, bw)) in zip(planes, tables, layout, strict=True):
        fh, fv = hmax // h, vmax // v
        padded = pad_edge(plane, -(-height // vmax) * vmax, bw * 8 * fh, xp)
        small = downsample(padded, fh, fv, xp)
        small = pad_edge(small, bh * 8, bw * 8, xp)
        coefs = fdct_islow(to_blocks(small - 128, xp), xp)
        if traced_tables:
            out.append(quantize_islow_traced(coefs, table, xp))
        else:
            out.append(quantize_islow(coefs, table, xp))
    return out


def inverse(coefficients, factors, tables, height: int, width: int, xp):
    """Quantized coefficient blocks `(rows, cols, 8, 8)` per component -> integer
    planes `(H, W)`, as libjpeg decodes them (islow IDCT, fancy upsampling)."""
    _, _, layout = component_layout(height, width, factors)
    samples = [
        from_blocks(idct_islow(coefs, table, xp), xp)[..., :h_c, :w_c]
        for coefs, table, (_, (h_c, w_c), _) in zip(coefficients, tables, layout, strict=True)
    ]
    return upsample_planes(samples, factors, height, width, xp)


def upsample_planes(samples, factors, height: int, width: int, xp):
    """Each component's samples (its real, downsampled size) -> `(H, W)` planes, as
    libjpeg upsamples them (fancy where it can, else replication)."""
    hmax, vmax, _ = component_layout(height, width, factors)
    planes = []
    for plane, (h, v) in zip(samples, factors, strict=True):
        fh, fv = hmax // h, vmax // v
        if (fh, fv) in ((1, 1), (2, 1), (1, 2), (2, 2)):
            full = upsample_fancy(plane, fh, fv, xp)
        else:
            full = xp.repeat(xp.repeat(plane, fv, axis=-2), fh, axis=-1)
        planes.append(pad_edge(full, height, width, xp)[..., :height, :width])
    return planes
