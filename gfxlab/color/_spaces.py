"""Colour spaces: chromaticity (xy, xyY), the spectral locus, sRGB and its transfer
function."""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import (
    as_float,
    check_finite,
    check_last_dim,
    check_shape,
    checked_jit,
    value_error_if,
)
from ._tables import CIE_WAVELENGTHS, D65_XY, _check_grid, _cmfs_at, _grid

# IEC 61966-2-1 XYZ -> linear sRGB matrix as published (colour-science uses the same);
# the inverse direction uses its exact inverse so that the round trip is exact.
_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)
_SRGB_TO_XYZ = np.linalg.inv(_XYZ_TO_SRGB)
_SRGB_LINEAR_LIMIT = 0.0031308  # linear value where the encoding switches to the power law


def _xyz_to_xy(xyz, black_xy):
    total = jnp.sum(xyz, axis=-1, keepdims=True)
    black = total == 0
    xy = xyz[..., :2] / jnp.where(black, 1.0, total)
    return jnp.where(black, black_xy.astype(xyz.dtype), xy)


@checked_jit
def _xyz_to_xy_checked(xyz, black_xy):
    return _xyz_to_xy(check_finite(xyz, "xyz"), check_finite(black_xy, "black_xy"))


def xyz_to_xy(
    xyz: Float[Array, "*batch 3"], *, black_xy: tuple[float, float] = D65_XY
) -> Float[Array, "*batch 2"]:
    """Chromaticity coordinates `x = X / (X + Y + Z)`, `y = Y / (X + Y + Z)`.

    **Arguments:**

    - `xyz`: `(..., 3)` tristimulus values.
    - `black_xy`: the chromaticity returned where `X + Y + Z = 0` (as colour-science
      does, the D65 white point by default).

    **Returns:** `(..., 2)` xy.
    """
    xyz = as_float(xyz, "xyz")
    check_last_dim(xyz, "xyz", (3,), "CIE XYZ")
    black_xy = as_float(black_xy, "black_xy")
    check_shape(black_xy, "black_xy", (2,))
    return _xyz_to_xy_checked(xyz, black_xy)


@checked_jit
def _xy_to_xyz(xy, big_y):
    xy = check_finite(xy, "xy")
    xy = value_error_if(xy, xy[..., 1] <= 0, "`xy` must have y > 0")
    x, y = xy[..., 0], xy[..., 1]
    big_y = jnp.broadcast_to(check_finite(big_y, "luminance").astype(xy.dtype), x.shape)
    return jnp.stack([x * big_y / y, big_y, (1.0 - x - y) * big_y / y], axis=-1)


def xy_to_xyz(xy: Float[Array, "*batch 2"], luminance=1.0) -> Float[Array, "*batch 3"]:
    """XYZ of chromaticity `xy` with `Y = luminance` (xyY to XYZ).

    **Arguments:**

    - `xy`: `(..., 2)` chromaticities with `y > 0`.
    - `luminance`: Y, broadcast against the batch shape.

    **Returns:** `(..., 3)` XYZ.
    """
    xy = as_float(xy, "xy")
    check_last_dim(xy, "xy", (2,), "chromaticity (x, y)")
    big_y = as_float(luminance, "luminance")
    try:
        fits = jnp.broadcast_shapes(big_y.shape, xy.shape[:-1]) == xy.shape[:-1]
    except ValueError:
        fits = False
    if not fits:
        raise ValueError(
            f"`luminance` must broadcast to the batch shape {xy.shape[:-1]} of `xy`, got "
            f"shape {big_y.shape}"
        )
    return _xy_to_xyz(xy, big_y)


@checked_jit
def _spectral_locus(wl):
    return _xyz_to_xy(_cmfs_at(_check_grid(wl)), jnp.asarray(D65_XY))


def spectral_locus(wavelengths=None) -> Float[Array, "N 2"]:
    """Chromaticities of monochromatic light, the horseshoe of the xy diagram.

    **Arguments:**

    - `wavelengths`: `(N,)` wavelengths in nm inside 360..830 (default the 1 nm grid).

    **Returns:** `(N, 2)` xy.
    """
    wavelengths = CIE_WAVELENGTHS if wavelengths is None else wavelengths
    return _spectral_locus(_grid(wavelengths))


def _encode(lin):
    power = lin > _SRGB_LINEAR_LIMIT
    safe = jnp.where(power, lin, 1.0)
    return jnp.where(power, 1.055 * safe ** (1 / 2.4) - 0.055, 12.92 * lin)


def _decode(enc):
    power = enc > 12.92 * _SRGB_LINEAR_LIMIT
    safe = jnp.where(power, enc, 1.0)
    return jnp.where(power, ((safe + 0.055) / 1.055) ** 2.4, enc / 12.92)


@checked_jit
def _srgb_encode(lin):
    return _encode(check_finite(lin, "linear"))


@checked_jit
def _srgb_decode(enc):
    return _decode(check_finite(enc, "encoded"))


def srgb_encode(linear: Float[Array, "..."]) -> Float[Array, "..."]:
    """The sRGB transfer function (IEC 61966-2-1): linear light to encoded values."""
    return _srgb_encode(as_float(linear, "linear"))


def srgb_decode(encoded: Float[Array, "..."]) -> Float[Array, "..."]:
    """The inverse sRGB transfer function: encoded values to linear light."""
    return _srgb_decode(as_float(encoded, "encoded"))


@functools.partial(checked_jit, static_argnames="encode")
def _xyz_to_srgb(xyz, encode):
    xyz = check_finite(xyz, "xyz")
    rgb = jnp.matmul(xyz, jnp.asarray(_XYZ_TO_SRGB, xyz.dtype).T)
    return _encode(rgb) if encode else rgb


@functools.partial(checked_jit, static_argnames="encoded")
def _srgb_to_xyz(rgb, encoded):
    rgb = check_finite(rgb, "rgb")
    lin = _decode(rgb) if encoded else rgb
    return jnp.matmul(lin, jnp.asarray(_SRGB_TO_XYZ, rgb.dtype).T)


def _flag(value, name: str) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"`{name}` must be True or False, got {value!r:.60}")
    return bool(value)


def xyz_to_srgb(xyz: Float[Array, "*batch 3"], *, encode: bool = True) -> Float[Array, "*batch 3"]:
    """CIE XYZ (D65 white, white Y = 1) to sRGB, not clipped.

    Equal to `colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=encode)`: the IEC
    61966-2-1 matrix, then the transfer function when `encode`. Out-of-gamut colours
    give values outside [0, 1]; clip them for display.

    **Arguments:**

    - `xyz`: `(..., 3)` XYZ scaled so that white has Y = 1.
    - `encode`: apply the sRGB transfer function (False gives linear sRGB).

    **Returns:** `(..., 3)` RGB.
    """
    xyz = as_float(xyz, "xyz")
    check_last_dim(xyz, "xyz", (3,), "CIE XYZ")
    return _xyz_to_srgb(xyz, _flag(encode, "encode"))


def srgb_to_xyz(rgb: Float[Array, "*batch 3"], *, encoded: bool = True) -> Float[Array, "*batch 3"]:
    """sRGB to CIE XYZ (white Y = 1), the exact inverse of `xyz_to_srgb`.

    **Arguments:**

    - `rgb`: `(..., 3)` sRGB values.
    - `encoded`: whether `rgb` carries the sRGB transfer function (False: linear).

    **Returns:** `(..., 3)` XYZ.
    """
    rgb = as_float(rgb, "rgb")
    check_last_dim(rgb, "rgb", (3,), "sRGB")
    return _srgb_to_xyz(rgb, _flag(encoded, "encoded"))
