"""Spectra to numbers: CIE XYZ (colorimetry), luminous flux, luminance and efficacy
(photometry), blackbody and line spectra."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._checks import as_float, check_finite, check_shape, checked_jit, value_error_if
from ._tables import K_M, _cell_widths, _check_grid, _cmfs_at, _grid, _spectrum, _v_at

# Radiation constants as in CIE 15:2004 and colour-science: c1 = 2 pi h c^2, c2 = h c / k.
_C1 = 3.741771e-16  # W m^2
_C2 = 1.4388e-2  # m K


def _common(*arrays) -> list[jax.Array]:
    """Arrays cast to their common dtype (None passes through)."""
    dtype = jnp.result_type(*[a for a in arrays if a is not None])
    return [None if a is None else a.astype(dtype) for a in arrays]


def _positive(x: jax.Array, name: str, unit: str) -> jax.Array:
    x = check_finite(x, name)
    return value_error_if(x, x <= 0, f"`{name}` must be positive ({unit})")


# --------------------------------------------------------------------------- colorimetry


@checked_jit
def _spectrum_to_xyz(wl, s, k, ill):
    wl, s, k, ill = _common(wl, s, k, ill)
    wl, s = _check_grid(wl), check_finite(s, "spd")
    weights = _cell_widths(wl)
    table = _cmfs_at(wl)
    ill = jnp.ones_like(wl) if ill is None else check_finite(ill, "illuminant")
    if k is None:
        white = jnp.sum(table[:, 1] * ill * weights)
        white = value_error_if(
            white,
            white == 0,
            "`k=None` normalises to Y = 100 of the illuminant (or of an equal-energy "
            "stimulus), whose Y is 0 on `wavelengths` (outside 360..830 nm?)",
        )
        k = 100.0 / white
    else:
        k = check_finite(k, "k")
    return k * jnp.matmul(s * ill * weights, table)


def spectrum_to_xyz(
    wavelengths: Float[Array, " N"],
    spd: Float[Array, "*batch N"],
    *,
    k: float | None = K_M,
    illuminant: Float[Array, " N"] | None = None,
) -> Float[Array, "*batch 3"]:
    """CIE XYZ tristimulus values of a spectrum (CIE 1931 2-degree observer).

    `XYZ = k * sum_l [xbar, ybar, zbar](l) * spd(l) * illuminant(l) * dl`, the CIE 15
    summation; identical to `colour.sd_to_XYZ(sd, cmfs, illuminant, k=k,
    method="Integration")` on the 1 nm grid (and on any uniform grid of whole
    nanometres).

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd`: `(..., N)` the stimulus: a spectral radiance, flux or power
      distribution, or, with `illuminant`, a reflectance or transmittance factor.
    - `k`: normalising constant. The default `K_M = 683` lm/W gives absolute values
      (Y in cd/m^2 for a radiance in W/(sr m^2 nm), in lm for a flux in W/nm).
      `None` normalises so that the illuminant (or, without one, a unit
      equal-energy stimulus) has Y = 100.
    - `illuminant`: optional `(N,)` spectral power distribution multiplied into `spd`.

    **Returns:** `(..., 3)` XYZ.

    Examples:
        >>> from gfxlab import color
        >>> wl = color.CIE_WAVELENGTHS
        >>> white = color.spectrum_to_xyz(wl, wl * 0 + 1.0, k=None)  # equal energy, Y = 100
        >>> [round(float(v), 2) for v in white]  # X = Y = Z up to the tables' rounding
        [100.01, 100.0, 100.03]
    """
    wl = _grid(wavelengths)
    s = _spectrum(spd, wl.shape[0], "spd")
    if k is not None:
        k = as_float(k, "k")
    if illuminant is not None:
        illuminant = _spectrum(illuminant, wl.shape[0], "illuminant")
        check_shape(illuminant, "illuminant", (wl.shape[0],))
    return _spectrum_to_xyz(wl, s, k, illuminant)


# --------------------------------------------------------------------------- photometry


def _photometric(wl, s):
    return jnp.trapezoid(_v_at(wl) * s, wl, axis=-1)


@functools.partial(checked_jit, static_argnames="names")
def _luminous_flux(wl, s, k_m, names):
    wl, s, k_m = _common(wl, s, k_m)
    wl, s = _check_grid(wl), check_finite(s, names[0])
    return check_finite(k_m, names[1]) * _photometric(wl, s)


def luminous_flux(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"], *, k_m: float = K_M
) -> Float[Array, "*batch"]:
    """The photometric integral `k_m * integral V(l) spd(l) dl` (trapezoid rule).

    Equal to `colour.luminous_flux`. A spectral flux in W/nm gives lumens; the same
    integral turns a spectral radiance into a luminance (`luminance`) and a spectral
    irradiance into an illuminance in lux.

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd`: `(..., N)` spectral flux in W/nm.
    - `k_m`: maximum luminous efficacy, 683 lm/W.

    **Returns:** `(...)` luminous flux in lm.
    """
    wl = _grid(wavelengths)
    s = _spectrum(spd, wl.shape[0], "spd")
    return _luminous_flux(wl, s, as_float(k_m, "k_m"), ("spd", "k_m"))


def luminance(
    wavelengths: Float[Array, " N"], radiance: Float[Array, "*batch N"]
) -> Float[Array, "*batch"]:
    """Luminance in cd/m^2 of a spectral radiance in W/(sr m^2 nm).

    `Y = 683 lm/W * integral V(l) L(l) dl`, the photometric analogue of radiance
    (one candela is one lumen per steradian).

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `radiance`: `(..., N)` spectral radiance.

    **Returns:** `(...)` luminance in cd/m^2.
    """
    wl = _grid(wavelengths)
    s = _spectrum(radiance, wl.shape[0], "radiance")
    return _luminous_flux(wl, s, K_M, ("radiance", "k_m"))


@checked_jit
def _efficiency(wl, s):
    wl, s = _common(wl, s)
    wl, s = _check_grid(wl), check_finite(s, "spd")
    total = jnp.trapezoid(s, wl, axis=-1)
    total = value_error_if(total, total <= 0, "`spd` must have positive total power")
    return _photometric(wl, s) / total


@checked_jit
def _efficacy(wl, s, power):
    wl, s, power = _common(wl, s, power)
    wl, s = _check_grid(wl), check_finite(s, "spd")
    power = _positive(power, "radiant_power", "in the units of `spd` times nm")
    return K_M * _photometric(wl, s) / power


def luminous_efficiency(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"]
) -> Float[Array, "*batch"]:
    """The fraction `integral V spd / integral spd` of power that counts as light.

    Dimensionless, 1 for light at 555 nm only; equal to `colour.luminous_efficiency`.

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd`: `(..., N)` a spectrum with positive total power on the grid.

    **Returns:** `(...)` efficiency in [0, 1].
    """
    wl = _grid(wavelengths)
    return _efficiency(wl, _spectrum(spd, wl.shape[0], "spd"))


def luminous_efficacy(
    wavelengths: Float[Array, " N"],
    spd: Float[Array, "*batch N"],
    *,
    radiant_power: Float[Array, "*batch"] | None = None,
) -> Float[Array, "*batch"]:
    """Lumens per watt: luminous flux over radiant power.

    Without `radiant_power` the power is integrated over the grid, so this equals
    `colour.luminous_efficacy` (683 lm/W for a 555 nm line). A source that also
    radiates outside the grid (an incandescent lamp radiates mostly in the infrared)
    needs its total power: pass e.g. `planck_total_radiance(T)` for a blackbody
    radiance from `planck`.

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `spd`: `(..., N)` spectral flux in W/nm (or radiance: the units cancel).
    - `radiant_power`: optional total radiant power in the units of `spd` times nm.

    **Returns:** `(...)` efficacy in lm/W.
    """
    wl = _grid(wavelengths)
    s = _spectrum(spd, wl.shape[0], "spd")
    if radiant_power is None:
        return K_M * _efficiency(wl, s)
    return _efficacy(wl, s, as_float(radiant_power, "radiant_power"))


# --------------------------------------------------------------------------- sources


@checked_jit
def _planck(wl, t):
    wl, t = _common(wl, t)
    wl = _positive(wl, "wavelengths", "nanometres")
    t = _positive(t, "temperature", "kelvin")
    lam = wl * 1e-9
    x = _C2 / (lam * t[..., None])
    # 1 / (exp(x) - 1) written with exp(-x) so that it and its gradient underflow to 0
    # instead of overflowing for cold bodies at short wavelengths.
    occupation = jnp.exp(-x) / -jnp.expm1(-x)
    return _C1 / (jnp.pi * lam**5) * occupation * 1e-9


def planck(
    wavelengths: Float[Array, " N"], temperature: Float[Array, "*batch"]
) -> Float[Array, "*batch N"]:
    """Blackbody spectral radiance (Planck's law) in W/(sr m^2 nm).

    `L(l, T) = c1 / (pi l^5) / (exp(c2 / (l T)) - 1)` with the CIE 15 constants
    `c1 = 3.741771e-16 W m^2`, `c2 = 1.4388e-2 m K` (colour-science's `planck_law`
    times 1e-9 per nm). Differentiable in `temperature`.

    **Arguments:**

    - `wavelengths`: `(N,)` positive wavelengths in nm (any order).
    - `temperature`: kelvin, positive; a batch of temperatures gives a batch of spectra.

    **Returns:** `(*batch, N)` spectral radiance.
    """
    wl = as_float(wavelengths, "wavelengths")
    check_shape(wl, "wavelengths", (None,))
    return _planck(wl, as_float(temperature, "temperature"))


@checked_jit
def _planck_total(t):
    t = _positive(t, "temperature", "kelvin")
    return jnp.pi**3 * _C1 / (15.0 * _C2**4) * t**4


def planck_total_radiance(temperature: Float[Array, "*batch"]) -> Float[Array, "*batch"]:
    """Blackbody radiance over all wavelengths, `sigma T^4 / pi`, in W/(sr m^2).

    Uses the same constants as `planck` (`sigma / pi = pi^3 c1 / (15 c2^4)`), so it is
    the integral of `planck` from 0 to infinity.
    """
    return _planck_total(as_float(temperature, "temperature"))


@checked_jit
def _line_spectrum(wl, centre, power):
    wl, centre, power = _common(wl, centre, power)
    wl = _check_grid(wl)
    centre = check_finite(centre, "line_wavelength")
    centre = value_error_if(
        centre,
        (centre < wl[0]) | (centre > wl[-1]),
        "`line_wavelength` must lie inside the `wavelengths` grid",
    )
    power = check_finite(power, "power")
    i = jnp.clip(jnp.searchsorted(wl, centre, side="right") - 1, 0, wl.shape[0] - 2)
    t = (centre - wl[i]) / (wl[i + 1] - wl[i])
    hat = jnp.zeros_like(wl).at[i].add(1.0 - t).at[i + 1].add(t)
    half_gaps = 0.5 * jnp.diff(wl)
    trapezoid_weights = jnp.zeros_like(wl).at[:-1].add(half_gaps).at[1:].add(half_gaps)
    return power * hat / trapezoid_weights


def line_spectrum(
    wavelengths: Float[Array, " N"], line_wavelength: Float[Array, ""], power=1.0
) -> Float[Array, " N"]:
    """A monochromatic line (a laser) of total `power` sampled on `wavelengths`.

    The power is shared linearly between the two samples around `line_wavelength`
    and divided by their integration weights, so that `luminous_flux` gives exactly
    `683 * V(line_wavelength) * power` (and `spectrum_to_xyz` the CMFs at the line
    times `683 * power`, unless the line sits in the first or last interval).

    **Arguments:**

    - `wavelengths`: `(N,)` strictly increasing, in nm.
    - `line_wavelength`: where the line is, inside the grid.
    - `power`: its radiant power (W, or W/(sr m^2) for a radiance), a scalar.

    **Returns:** `(N,)` spectral density (power per nm).
    """
    wl = _grid(wavelengths)
    centre = as_float(line_wavelength, "line_wavelength")
    check_shape(centre, "line_wavelength", ())
    power = as_float(power, "power")
    check_shape(power, "power", ())
    return _line_spectrum(wl, centre, power)
