"""Metamers: spectra the standard observer cannot tell apart (Cohen's fundamental
metamer, metameric blacks, Grassmann matches)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._checks import (
    as_float,
    check_allocation,
    check_finite,
    check_shape,
    checked_jit,
    value_error_if,
)
from ._spectra import _common, _spectrum_to_xyz
from ._tables import K_M, _cell_widths, _check_grid, _cmfs_at, _grid, _spectrum


def _cmf_matrix(wl: jax.Array) -> jax.Array:
    """The `(3, N)` matrix A with `spectrum_to_xyz(wl, s) == K_M * A @ s`."""
    return (_cmfs_at(wl) * _cell_widths(wl)[:, None]).T


def _fundamental(wl, s):
    a = _cmf_matrix(wl)
    coeffs = jnp.linalg.solve(a @ a.T, jnp.matmul(s, a.T)[..., None])[..., 0]
    return jnp.matmul(coeffs, a)


def _checked(wl, s, name="spd"):
    wl, s = _common(wl, s)
    return _check_grid(wl), check_finite(s, name)


@checked_jit
def _fundamental_metamer(wl, s):
    return _fundamental(*_checked(wl, s))


@checked_jit
def _metameric_black(wl, s):
    wl, s = _checked(wl, s)
    return s - _fundamental(wl, s)


def fundamental_metamer(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"]
) -> Float[Array, "*batch N"]:
    """Cohen's fundamental metamer: the part of `spd` the observer sees.

    The orthogonal projection of `spd` onto the span of the (weighted) colour-matching
    functions, `A^T (A A^T)^-1 A spd`. Every spectrum is its fundamental metamer plus
    a metameric black, and two spectra match iff their fundamental metamers are equal.

    **Returns:** `(..., N)` the fundamental metamer (same XYZ as `spd`).
    """
    wl = _grid(wavelengths)
    return _fundamental_metamer(wl, _spectrum(spd, wl.shape[0], "spd"))


def metameric_black(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"]
) -> Float[Array, "*batch N"]:
    """The part of `spd` the observer cannot see: XYZ of the result is zero.

    `spd - fundamental_metamer(spd)`; adding it to any spectrum leaves XYZ unchanged.
    """
    wl = _grid(wavelengths)
    return _metameric_black(wl, _spectrum(spd, wl.shape[0], "spd"))


@checked_jit
def _black_basis(wl):
    _, _, vt = jnp.linalg.svd(_cmf_matrix(_check_grid(wl)), full_matrices=True)
    return vt[3:].T


def metameric_black_basis(wavelengths: Float[Array, " N"]) -> Float[Array, "N N-3"]:
    """An orthonormal basis of the metameric blacks on `wavelengths` (null space of XYZ).

    **Returns:** `(N, N - 3)` columns `b` with `spectrum_to_xyz(wavelengths, b.T) == 0`
    (to rounding). Spectra that differ by any combination of them are metamers.
    """
    wl = _grid(wavelengths)
    if wl.shape[0] <= 3:
        raise ValueError("`wavelengths` needs more than 3 samples to have metameric blacks")
    check_allocation(wl.shape[0] ** 2, "wavelengths")
    return _black_basis(wl)


@functools.partial(checked_jit, static_argnames="keep_nonnegative")
def _make_metamer(wl, s, p, keep_nonnegative):
    wl, s, p = _common(wl, s, p)
    wl, s = _checked(wl, s)
    p = check_finite(p, "perturbation")
    black = p - _fundamental(wl, p)
    if not keep_nonnegative:
        return s + black
    negative = black < 0
    room = jnp.where(negative, jnp.maximum(s, 0.0) / jnp.where(negative, -black, 1.0), jnp.inf)
    # A few ulps of margin keep `s + t * black >= 0` whatever the rounding (an FMA, say)
    # at the sample that limits `t`; any `t` gives an exact metamer.
    margin = 1.0 - 4.0 * jnp.finfo(s.dtype).eps
    t = jnp.minimum(1.0, margin * jnp.min(room, axis=-1, keepdims=True))
    return s + t * black


def make_metamer(
    wavelengths: Float[Array, " N"],
    spd: Float[Array, "*batch N"],
    perturbation: Float[Array, "*batch N"],
    *,
    keep_nonnegative: bool = True,
) -> Float[Array, "*batch N"]:
    """A spectrum that looks the same as `spd`: `spd + t * metameric_black(perturbation)`.

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd`: `(..., N)` the spectrum to match.
    - `perturbation`: `(..., N)` any spectrum; its visible part is removed first.
    - `keep_nonnegative`: shrink `t` from 1 so that the metamer stays physical
      (non-negative) where `spd` is; otherwise `t = 1`.

    **Returns:** `(..., N)` a metamer of `spd` (equal XYZ).
    """
    wl = _grid(wavelengths)
    s = _spectrum(spd, wl.shape[0], "spd")
    p = _spectrum(perturbation, wl.shape[0], "perturbation")
    if not isinstance(keep_nonnegative, bool | np.bool_):
        raise TypeError(f"`keep_nonnegative` must be True or False, got {keep_nonnegative!r:.60}")
    return _make_metamer(wl, s, p, bool(keep_nonnegative))


@checked_jit
def _metameric_match(wl, a, b, rtol):
    wl, a, b, rtol = _common(wl, a, b, rtol)
    a, b = check_finite(a, "spd_a"), check_finite(b, "spd_b")
    rtol = check_finite(rtol, "rtol")
    rtol = value_error_if(rtol, rtol < 0, "`rtol` must be >= 0")
    k = jnp.asarray(K_M, wl.dtype)
    xyz_a = _spectrum_to_xyz.__wrapped__(wl, a, k, None)
    xyz_b = _spectrum_to_xyz.__wrapped__(wl, b, k, None)
    scale = jnp.maximum(jnp.maximum(jnp.abs(xyz_a), jnp.abs(xyz_b)).max(axis=-1), 1e-300)
    return jnp.max(jnp.abs(xyz_a - xyz_b), axis=-1) <= rtol * scale


def metameric_match(
    wavelengths: Float[Array, " N"],
    spd_a: Float[Array, "*batch N"],
    spd_b: Float[Array, "*batch N"],
    *,
    rtol: float = 1e-9,
) -> Bool[Array, "*batch"]:
    """Whether two spectra match for the standard observer (equal XYZ within `rtol`).

    The tolerance is relative to the largest tristimulus value of the pair, so black
    matches black.

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd_a`, `spd_b`: `(..., N)` the two spectra.
    - `rtol`: relative tolerance, finite and >= 0.

    **Returns:** `(...)` booleans.
    """
    wl = _grid(wavelengths)
    a = _spectrum(spd_a, wl.shape[0], "spd_a")
    b = _spectrum(spd_b, wl.shape[0], "spd_b")
    rtol = as_float(rtol, "rtol")
    check_shape(rtol, "rtol", ())
    return _metameric_match(wl, a, b, rtol)
