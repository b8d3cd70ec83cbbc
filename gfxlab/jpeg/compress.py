"""`compress`: a differentiable JPEG round trip whose forward pass is libjpeg's.

The value is computed by the bit-exact integer pipeline (`_libjpeg.forward` then
`_libjpeg.inverse`, in `jax.numpy`, jittable): exactly what Pillow gives for
`Image.open(save(image, quality=round(q)))`. Gradients come from a floating-point
twin of the same pipeline (`gfxlab.jpeg.stages`) whose rounding is straight-through
(dead-zone aware by default) or cubic and whose quantization tables are a smooth
function of `quality`; the two
are joined as `twin + stop_gradient(exact - twin)`.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gfxlab._checks import (
    as_float,
    attach_check,
    check_finite,
    check_range,
    check_shape,
    checked_jit,
    finite_float,
    trusted_values,
    value_error_if,
)
from gfxlab._pixels import from_levels, to_levels
from gfxlab.jpeg import _libjpeg as L
from gfxlab.jpeg import stages as S
from gfxlab.jpeg._tables import SUBSAMPLING, ijg_tables

__all__ = ["compress", "exact_tables"]


def exact_tables(quality) -> tuple[Array, Array]:
    """IJG integer tables for a possibly traced quality (rounded to an integer).

    **Arguments:**

    - `quality`: scalar in [1, 100] (may be traced, e.g. a fitted parameter; outside
      the range a `ValueError`, eagerly and under `jax.jit`).

    **Returns:**

    `(luminance, chrominance)` int32 `(8, 8)` tables, equal to `quant_tables`.
    """
    q = check_range(finite_float(quality, "quality"), "quality", minimum=1.0, maximum=100.0)
    q = jnp.clip(jnp.round(q), 1, 100).astype(jnp.int32)
    return ijg_tables(q, jnp)


def _exact(image, quality, factors):
    u8 = to_levels(jax.lax.stop_gradient(image))
    luma, chroma = exact_tables(jax.lax.stop_gradient(quality))
    height, width = image.shape[:2]
    if image.ndim == 2:
        planes, tables = [u8], [luma]
    else:
        planes, tables = list(L.rgb_to_ycc(u8, jnp)), [luma, chroma, chroma]
    coefs = L.forward(planes, factors, tables, jnp, traced_tables=True)
    planes = L.inverse(coefs, factors, tables, height, width, jnp)
    if image.ndim == 2:
        return from_levels(planes[0], image.dtype)
    return from_levels(L.ycc_to_rgb(*planes, jnp), image.dtype)


def _twin(image, quality, factors, rounding):
    luma, chroma = S.quant_tables_continuous(quality)
    height, width = image.shape[:2]
    hmax = max(f[0] for f in factors)
    vmax = max(f[1] for f in factors)
    if image.ndim == 2:
        planes, tables = [image * 255.0], [luma]
    else:
        ycc = S.rgb_to_ycbcr(image) * 255.0
        planes, tables = [ycc[..., i] for i in range(3)], [luma, chroma, chroma]
    out = []
    for plane, table, (h, v) in zip(planes, tables, factors, strict=True):
        name = {(1, 1): "4:4:4", (2, 1): "4:2:2", (2, 2): "4:2:0"}[(hmax // h, vmax // v)]
        small = S.subsample(plane, subsampling=name)
        coefs = S.dct2(S.level_shift(S.blocks(small)))
        rec = S.idct2(
            S.dequantize(S.quantize(coefs, table.astype(coefs.dtype), rounding=rounding), table)
        )
        rec = S.unblocks(S.level_shift(rec, inverse=True), small.shape)
        out.append(S.upsample(rec, (height, width), subsampling=name))
    if image.ndim == 2:
        return out[0] / 255.0
    return S.ycbcr_to_rgb(jnp.stack(out, axis=-1) / 255.0)


def compress(
    image: Float[Array, "H W *channels"],
    *,
    quality,
    subsampling: str = "4:2:0",
    rounding: str = "deadzone",
) -> Float[Array, "H W *channels"]:
    """Differentiable JPEG round trip (encode then decode).

    Forward: exactly libjpeg-turbo's result (what Pillow returns after saving with
    `quality=round(quality)` and reading back), pixels in [0, 1]. Backward: a float
    twin of the pipeline with `rounding`:

    - `"deadzone"` (default): straight-through for the image; w.r.t. the tables
      (so `quality`) a coefficient rounded to zero counts a quarter. Checked against
      central differences of the exact pipeline (the staircase in `quality`): right
      sign and within 2x at q = 20, 50, 80 on test photos;
    - `"ste"`: straight-through rounding (`d round(x)/dx = 1`); its d/d(quality) is
      2-4x too large (dead-zone coefficients count as if they still moved);
    - `"cubic"`: soft rounding `round(x) + (x - round(x))**3`; its d/d(quality)
      can have the wrong sign (use it for image gradients only).

    `quality` is continuous: the twin's tables follow IJG's scale curve smoothly, so
    `d image / d quality` is finite on all of [1, 100]. It is zero where every table
    entry is clamped (to 255 below q = 2, to 1 at q = 100): start a fit of `quality`
    inside, say in [5, 95].

    **Arguments:**

    - `image`: `(H, W, 3)` RGB or `(H, W)` grey, float in [0, 1] (an integer image is a
      `TypeError`; values outside [0, 1] a `ValueError`, eagerly and under `jax.jit`).
    - `quality`: scalar in [1, 100] (may be traced).
    - `subsampling`: `"4:4:4"`, `"4:2:2"` or `"4:2:0"` (ignored for grey).
    - `rounding`: `"deadzone"`, `"ste"` or `"cubic"`.

    **Returns:**

    The decoded image, same shape and dtype as `image`.
    """
    dtype = getattr(image, "dtype", None)  # (lists and None: as_float's checks below)
    if dtype is not None and not jnp.issubdtype(dtype, jnp.floating):
        # uint8 levels would be read as values far above 1 and decoded as white
        raise TypeError(
            f"`image` must be a floating-point image in [0, 1], got dtype {dtype} "
            "(divide uint8 levels by 255)"
        )
    image = as_float(image, "image")  # its values are checked inside `_compress`
    if image.ndim == 3 and image.shape[-1] == 1:
        return compress(image[..., 0], quality=quality, subsampling=subsampling, rounding=rounding)[
            ..., None
        ]
    if image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[-1] != 3):
        raise ValueError(f"`image` must have shape (H, W) or (H, W, 3), got {image.shape}")
    if 0 in image.shape[:2]:
        raise ValueError(f"`image` must not be empty, got shape {image.shape}")
    if subsampling not in SUBSAMPLING:
        raise ValueError(f"`subsampling` must be one of {sorted(SUBSAMPLING)}, got {subsampling!r}")
    if rounding not in ("deadzone", "ste", "cubic"):
        raise ValueError(f"`rounding` must be 'deadzone', 'ste' or 'cubic', got {rounding!r}")
    if isinstance(quality, int | float) and not isinstance(quality, bool):
        quality = check_finite(np.float64(quality), "quality")  # on the host: no dispatch
    else:
        quality = finite_float(quality, "quality")
    if quality.ndim != 0:
        raise ValueError(f"`quality` must be a scalar, got shape {quality.shape}")
    quality = check_range(quality, "quality", minimum=1.0, maximum=100.0)
    factors = ((1, 1),) if image.ndim == 2 else (SUBSAMPLING[subsampling], (1, 1), (1, 1))
    return _compress(image, quality, factors, rounding)


@functools.partial(checked_jit, static_argnums=(2, 3))
def _compress(image, quality, factors, rounding):
    """The array work of `compress`, one compiled program per shape and options: the
    value check of `image` too (NumPy's eager check of a 512 x 512 photo cost a third of
    the whole call)."""
    with trusted_values():  # the stages see checked inputs: their own checks are moot
        quality = quality.astype(image.dtype)
        twin = _twin(image, quality, list(factors), rounding)
        out = twin + jax.lax.stop_gradient(_exact(image, quality, list(factors)) - twin)
    # NaN fails both comparisons: one check refuses NaN, inf and values outside [0, 1]
    outside = ~((image >= 0) & (image <= 1))
    return attach_check(out, outside, "`image` must be in [0, 1] (no NaN or inf)")


def psnr(a, b, *, peak: float = 1.0) -> Array:
    """Peak signal-to-noise ratio `10 log10(peak**2 / MSE)` in dB.

    **Arguments:**

    - `a`, `b`: images of the same shape.
    - `peak`: the largest possible value (1 for float images, 255 for uint8).

    **Returns:**

    Scalar PSNR (inf for identical images).
    """
    a, b = finite_float(a, "a"), finite_float(b, "b")
    if a.size == 0:
        raise ValueError(f"`a` must not be empty, got shape {a.shape}")
    check_shape(b, "b", a.shape)
    peak = finite_float(peak, "peak")
    check_shape(peak, "peak", ())
    peak = value_error_if(peak, peak <= 0, "`peak` must be positive (the largest value)")
    mse = jnp.mean((a - b) ** 2)
    return 10 * jnp.log10(peak**2 / mse)
