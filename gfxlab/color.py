"""Colorimetry and photometry: CMFs, V(lambda), XYZ, sRGB, luminance, luminous flux.

Spectra are sampled on an increasing wavelength grid in nanometres: `wavelengths`
of shape `(N,)` and a spectral power distribution `spd` of shape `(..., N)` (a batch
of spectra shares one grid). The observer tables (CIE 1931 2-degree colour-matching
functions xbar, ybar, zbar and the CIE 1924 photopic luminous efficiency function
V(lambda), 360..830 nm at 1 nm) come from colour-science through the generated
table `data/color/cie_observer.csv`; they are read on first use, and colour-science
itself is only imported if the table is missing (a non-editable install). Off the
1 nm grid the tables are interpolated linearly, and they are zero outside
360..830 nm.

Two integration rules, each matching colour-science exactly:

- **Colorimetry** (`spectrum_to_xyz`) uses the CIE 15 summation
  `XYZ = k * sum(xyz(l) * S(l) * dl)` (colour-science's `method="Integration"`). On a
  non-uniform grid `dl` is the width of the cell around each sample.
- **Photometry** (`luminous_flux`, `luminance`, `luminous_efficiency`,
  `luminous_efficacy`) uses the trapezoid rule, as `colour.luminous_flux` does.

With `k = K_M = 683 lm/W` the results are absolute: Y of a spectral radiance in
W/(sr m^2 nm) is a luminance in cd/m^2, Y of a spectral flux in W/nm is a luminous
flux in lm. The two rules differ only in the half weights at the two ends of the
grid, where the observer functions are nearly zero.

Example:
    >>> import jax.numpy as jnp
    >>> from gfxlab import color
    >>> wl = color.CIE_WAVELENGTHS
    >>> laser = color.line_spectrum(wl, 555.0, power=1.0)  # 1 W at 555 nm
    >>> round(float(color.luminous_efficacy(wl, laser)), 6)  # 683 lm/W
    683.0
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from ._checks import check_last_dim, check_shape, finite_float, is_traced, value_error_if
from ._resources import data_folder

__all__ = [
    "K_M",
    "CIE_WAVELENGTHS",
    "D65_XY",
    "SRGB_PRIMARIES_XY",
    "cmfs",
    "v_lambda",
    "illuminant_d65",
    "spectrum_to_xyz",
    "xyz_to_xy",
    "xy_to_xyz",
    "spectral_locus",
    "srgb_encode",
    "srgb_decode",
    "xyz_to_srgb",
    "srgb_to_xyz",
    "luminous_flux",
    "luminance",
    "luminous_efficiency",
    "luminous_efficacy",
    "planck",
    "planck_total_radiance",
    "line_spectrum",
    "fundamental_metamer",
    "metameric_black",
    "metameric_black_basis",
    "make_metamer",
    "metameric_match",
]

#: Maximum luminous efficacy of photopic vision, lm/W (the SI definition of the candela
#: fixes 683 lm/W at 540 THz, about 555 nm).
K_M = 683.0

#: The observer tables' grid: 360..830 nm in 1 nm steps (a NumPy array).
CIE_WAVELENGTHS = np.arange(360.0, 831.0)

#: Chromaticity of CIE illuminant D65 (2-degree observer), the sRGB white point.
D65_XY = (0.3127, 0.3290)

#: Chromaticities of the sRGB (ITU-R BT.709) red, green and blue primaries.
SRGB_PRIMARIES_XY = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))

# IEC 61966-2-1 XYZ -> linear sRGB matrix as published (colour-science uses the same);
# the inverse direction uses its exact inverse so that the round trip is exact.
_XYZ_TO_SRGB = np.array(
    [[3.2406, -1.5372, -0.4986], [-0.9689, 1.8758, 0.0415], [0.0557, -0.2040, 1.0570]]
)
_SRGB_TO_XYZ = np.linalg.inv(_XYZ_TO_SRGB)
_SRGB_LINEAR_LIMIT = 0.0031308  # linear value where the encoding switches to the power law

# Radiation constants as in CIE 15:2004 and colour-science: c1 = 2 pi h c^2, c2 = h c / k.
_C1 = 3.741771e-16  # W m^2
_C2 = 1.4388e-2  # m K

#: The shipped CIE tables (`data/color/` of the project, `gfxlab._data` in a wheel).
DATA_DIR = data_folder("color")


# --------------------------------------------------------------------------- tables


@functools.cache
def _tables() -> dict[str, np.ndarray]:
    """The observer and D65 tables as float64 NumPy arrays, read once."""
    observer = DATA_DIR / "cie_observer.csv"
    d65 = DATA_DIR / "cie_d65.csv"
    if observer.is_file() and d65.is_file():
        obs = np.loadtxt(observer, delimiter=",", skiprows=1)
        ill = np.loadtxt(d65, delimiter=",", skiprows=1)
        return {
            "wavelengths": obs[:, 0],
            "cmfs": obs[:, 1:4],
            "v": obs[:, 4],
            "d65_wavelengths": ill[:, 0],
            "d65": ill[:, 1],
        }
    import colour  # the tables were not shipped with this install
    from colour.colorimetry import SDS_LEFS_PHOTOPIC

    cmf = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    lef = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    ill = colour.SDS_ILLUMINANTS["D65"]
    return {
        "wavelengths": np.asarray(cmf.wavelengths, float),
        "cmfs": np.asarray(cmf.values, float),
        "v": np.asarray(lef.values, float),
        "d65_wavelengths": np.asarray(ill.wavelengths, float),
        "d65": np.asarray(ill.values, float),
    }


def _check_wavelengths(wavelengths, name: str = "wavelengths") -> jax.Array:
    wl = finite_float(wavelengths, name)
    if wl.ndim != 1 or wl.shape[0] < 2:
        raise ValueError(
            f"`{name}` must be a 1-D grid of at least 2 wavelengths in nm, got shape "
            f"{tuple(wl.shape)}"
        )
    wl = value_error_if(wl, wl[0] <= 0, f"`{name}` must be positive (nanometres)")
    return value_error_if(
        wl, jnp.any(jnp.diff(wl) <= 0), f"`{name}` must be strictly increasing (nanometres)"
    )


def _on_table_grid(wl: jax.Array) -> bool:
    """True when `wl` is known (concretely) to be exactly the tables' 1 nm grid."""
    return (
        not is_traced(wl)
        and wl.shape == CIE_WAVELENGTHS.shape
        and bool(np.array_equal(np.asarray(wl), CIE_WAVELENGTHS))
    )


def _resample(wl: jax.Array, grid: np.ndarray, values: np.ndarray) -> jax.Array:
    """Table `values` (rows on `grid`) at `wl`, linear in between, zero outside."""
    if _on_table_grid(wl) and np.array_equal(grid, CIE_WAVELENGTHS):
        return jnp.asarray(values, wl.dtype)
    table = jnp.asarray(values, wl.dtype)
    xp = jnp.asarray(grid, wl.dtype)
    if table.ndim == 1:
        return jnp.interp(wl, xp, table, left=0.0, right=0.0)
    columns = [jnp.interp(wl, xp, table[:, i], left=0.0, right=0.0) for i in range(table.shape[1])]
    return jnp.stack(columns, axis=-1)


def cmfs(wavelengths=None) -> Float[Array, "N 3"]:
    """The CIE 1931 2-degree colour-matching functions xbar, ybar, zbar.

    **Arguments:**

    - `wavelengths`: `(N,)` increasing wavelengths in nm (default: `CIE_WAVELENGTHS`,
      where the tabulated values are returned exactly).

    **Returns:** `(N, 3)` values, linearly interpolated, zero outside 360..830 nm.
    """
    wl = _check_wavelengths(CIE_WAVELENGTHS if wavelengths is None else wavelengths)
    t = _tables()
    return _resample(wl, t["wavelengths"], t["cmfs"])


def v_lambda(wavelengths=None) -> Float[Array, " N"]:
    """The CIE 1924 photopic luminous efficiency function V(lambda) (peak 1 at 555 nm).

    **Arguments:**

    - `wavelengths`: `(N,)` increasing wavelengths in nm (default `CIE_WAVELENGTHS`).

    **Returns:** `(N,)` values, linearly interpolated, zero outside 360..830 nm.
    """
    wl = _check_wavelengths(CIE_WAVELENGTHS if wavelengths is None else wavelengths)
    t = _tables()
    return _resample(wl, t["wavelengths"], t["v"])


def illuminant_d65() -> tuple[Float[Array, " M"], Float[Array, " M"]]:
    """CIE standard illuminant D65 as tabulated (300..780 nm, 5 nm; 100 at 560 nm).

    **Returns:** `(wavelengths, relative_spd)`.
    """
    t = _tables()
    return jnp.asarray(t["d65_wavelengths"]), jnp.asarray(t["d65"])


def _cell_widths(wl: jax.Array) -> jax.Array:
    """Summation weights: the width of the cell around each sample.

    Interior samples get half the distance between their neighbours, the two end
    samples a full step, so a uniform grid gets its interval everywhere (CIE 15).
    """
    gaps = jnp.diff(wl)
    inner = 0.5 * (gaps[1:] + gaps[:-1])
    return jnp.concatenate([gaps[:1], inner, gaps[-1:]])


def _spectrum(spd, wl: jax.Array, name: str = "spd") -> jax.Array:
    s = finite_float(spd, name)
    if s.ndim == 0 or s.shape[-1] != wl.shape[0]:
        raise ValueError(
            f"`{name}` must have shape (..., {wl.shape[0]}) to match `wavelengths`, got shape "
            f"{tuple(s.shape)}"
        )
    return s


def _promote(wavelengths, spd, name: str = "spd") -> tuple[jax.Array, jax.Array]:
    wl = _check_wavelengths(wavelengths)
    s = _spectrum(spd, wl, name)
    dtype = jnp.result_type(wl, s)
    return wl.astype(dtype), s.astype(dtype)


# --------------------------------------------------------------------------- colorimetry


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
    """
    wl, s = _promote(wavelengths, spd)
    weights = _cell_widths(wl)
    table = cmfs(wl).astype(wl.dtype)
    if illuminant is not None:
        ill = _spectrum(illuminant, wl, "illuminant").astype(wl.dtype)
        check_shape(ill, "illuminant", (wl.shape[0],))
    else:
        ill = jnp.ones_like(wl)
    if k is None:
        k = 100.0 / jnp.sum(table[:, 1] * ill * weights)
    return k * jnp.matmul(s * ill * weights, table)


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
    xyz = finite_float(xyz, "xyz")
    check_last_dim(xyz, "xyz", (3,), "CIE XYZ")
    total = jnp.sum(xyz, axis=-1, keepdims=True)
    black = total == 0
    xy = xyz[..., :2] / jnp.where(black, 1.0, total)
    return jnp.where(black, jnp.asarray(black_xy, xyz.dtype), xy)


def xy_to_xyz(xy: Float[Array, "*batch 2"], luminance=1.0) -> Float[Array, "*batch 3"]:
    """XYZ of chromaticity `xy` with `Y = luminance` (xyY to XYZ).

    **Arguments:**

    - `xy`: `(..., 2)` chromaticities with `y > 0`.
    - `luminance`: Y, broadcast against the batch shape.

    **Returns:** `(..., 3)` XYZ.
    """
    xy = finite_float(xy, "xy")
    check_last_dim(xy, "xy", (2,), "chromaticity (x, y)")
    xy = value_error_if(xy, xy[..., 1] <= 0, "`xy` must have y > 0")
    x, y = xy[..., 0], xy[..., 1]
    big_y = finite_float(luminance, "luminance").astype(xy.dtype)
    big_y = jnp.broadcast_to(big_y, x.shape)
    return jnp.stack([x * big_y / y, big_y, (1.0 - x - y) * big_y / y], axis=-1)


def spectral_locus(wavelengths=None) -> Float[Array, "N 2"]:
    """Chromaticities of monochromatic light, the horseshoe of the xy diagram.

    **Arguments:**

    - `wavelengths`: `(N,)` wavelengths in nm inside 360..830 (default the 1 nm grid).

    **Returns:** `(N, 2)` xy.
    """
    return xyz_to_xy(cmfs(wavelengths))


def srgb_encode(linear: Float[Array, "..."]) -> Float[Array, "..."]:
    """The sRGB transfer function (IEC 61966-2-1): linear light to encoded values."""
    lin = finite_float(linear, "linear")
    power = lin > _SRGB_LINEAR_LIMIT
    safe = jnp.where(power, lin, 1.0)
    return jnp.where(power, 1.055 * safe ** (1 / 2.4) - 0.055, 12.92 * lin)


def srgb_decode(encoded: Float[Array, "..."]) -> Float[Array, "..."]:
    """The inverse sRGB transfer function: encoded values to linear light."""
    enc = finite_float(encoded, "encoded")
    power = enc > 12.92 * _SRGB_LINEAR_LIMIT
    safe = jnp.where(power, enc, 1.0)
    return jnp.where(power, ((safe + 0.055) / 1.055) ** 2.4, enc / 12.92)


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
    xyz = finite_float(xyz, "xyz")
    check_last_dim(xyz, "xyz", (3,), "CIE XYZ")
    rgb = jnp.matmul(xyz, jnp.asarray(_XYZ_TO_SRGB, xyz.dtype).T)
    return srgb_encode(rgb) if encode else rgb


def srgb_to_xyz(rgb: Float[Array, "*batch 3"], *, encoded: bool = True) -> Float[Array, "*batch 3"]:
    """sRGB to CIE XYZ (white Y = 1), the exact inverse of `xyz_to_srgb`.

    **Arguments:**

    - `rgb`: `(..., 3)` sRGB values.
    - `encoded`: whether `rgb` carries the sRGB transfer function (False: linear).

    **Returns:** `(..., 3)` XYZ.
    """
    rgb = finite_float(rgb, "rgb")
    check_last_dim(rgb, "rgb", (3,), "sRGB")
    lin = srgb_decode(rgb) if encoded else rgb
    return jnp.matmul(lin, jnp.asarray(_SRGB_TO_XYZ, rgb.dtype).T)


# --------------------------------------------------------------------------- photometry


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
    return _luminous_flux(wavelengths, spd, "spd", k_m)


def _luminous_flux(wavelengths, spd, name: str, k_m=K_M) -> jax.Array:
    wl, s = _promote(wavelengths, spd, name)
    k_m = finite_float(k_m, "k_m").astype(s.dtype)
    return k_m * jnp.trapezoid(v_lambda(wl) * s, wl, axis=-1)


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
    return _luminous_flux(wavelengths, radiance, "radiance")


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
    wl, s = _promote(wavelengths, spd)
    total = jnp.trapezoid(s, wl, axis=-1)
    total = value_error_if(total, total <= 0, "`spd` must have positive total power")
    return jnp.trapezoid(v_lambda(wl) * s, wl, axis=-1) / total


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
    if radiant_power is None:
        return K_M * luminous_efficiency(wavelengths, spd)
    power = finite_float(radiant_power, "radiant_power")
    power = value_error_if(power, power <= 0, "`radiant_power` must be positive")
    return luminous_flux(wavelengths, spd) / power


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
    wl = finite_float(wavelengths, "wavelengths")
    check_shape(wl, "wavelengths", (None,))
    t = finite_float(temperature, "temperature")
    dtype = jnp.result_type(wl, t)
    wl, t = wl.astype(dtype), t.astype(dtype)
    wl = value_error_if(wl, wl <= 0, "`wavelengths` must be positive (nanometres)")
    t = value_error_if(t, t <= 0, "`temperature` must be positive (kelvin)")
    lam = wl * 1e-9
    x = _C2 / (lam * t[..., None])
    # 1 / (exp(x) - 1) written with exp(-x) so that it and its gradient underflow to 0
    # instead of overflowing for cold bodies at short wavelengths.
    occupation = jnp.exp(-x) / -jnp.expm1(-x)
    return _C1 / (jnp.pi * lam**5) * occupation * 1e-9


def planck_total_radiance(temperature: Float[Array, "*batch"]) -> Float[Array, "*batch"]:
    """Blackbody radiance over all wavelengths, `sigma T^4 / pi`, in W/(sr m^2).

    Uses the same constants as `planck` (`sigma / pi = pi^3 c1 / (15 c2^4)`), so it is
    the integral of `planck` from 0 to infinity.
    """
    t = finite_float(temperature, "temperature")
    t = value_error_if(t, t <= 0, "`temperature` must be positive (kelvin)")
    return jnp.pi**3 * _C1 / (15.0 * _C2**4) * t**4


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
    - `power`: its radiant power (W, or W/(sr m^2) for a radiance).

    **Returns:** `(N,)` spectral density (power per nm).
    """
    wl = _check_wavelengths(wavelengths)
    centre = finite_float(line_wavelength, "line_wavelength").astype(wl.dtype)
    check_shape(centre, "line_wavelength", ())
    centre = value_error_if(
        centre,
        (centre < wl[0]) | (centre > wl[-1]),
        "`line_wavelength` must lie inside the `wavelengths` grid",
    )
    i = jnp.clip(jnp.searchsorted(wl, centre, side="right") - 1, 0, wl.shape[0] - 2)
    t = (centre - wl[i]) / (wl[i + 1] - wl[i])
    hat = jnp.zeros_like(wl).at[i].add(1.0 - t).at[i + 1].add(t)
    half_gaps = 0.5 * jnp.diff(wl)
    trapezoid_weights = jnp.zeros_like(wl).at[:-1].add(half_gaps).at[1:].add(half_gaps)
    return finite_float(power, "power").astype(wl.dtype) * hat / trapezoid_weights


# --------------------------------------------------------------------------- metamers


def _cmf_matrix(wl: jax.Array) -> jax.Array:
    """The `(3, N)` matrix A with `spectrum_to_xyz(wl, s) == K_M * A @ s`."""
    return (cmfs(wl) * _cell_widths(wl)[:, None]).T


def fundamental_metamer(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"]
) -> Float[Array, "*batch N"]:
    """Cohen's fundamental metamer: the part of `spd` the observer sees.

    The orthogonal projection of `spd` onto the span of the (weighted) colour-matching
    functions, `A^T (A A^T)^-1 A spd`. Every spectrum is its fundamental metamer plus
    a metameric black, and two spectra match iff their fundamental metamers are equal.

    **Returns:** `(..., N)` the fundamental metamer (same XYZ as `spd`).
    """
    wl, s = _promote(wavelengths, spd)
    a = _cmf_matrix(wl)
    coeffs = jnp.linalg.solve(a @ a.T, jnp.matmul(s, a.T)[..., None])[..., 0]
    return jnp.matmul(coeffs, a)


def metameric_black(
    wavelengths: Float[Array, " N"], spd: Float[Array, "*batch N"]
) -> Float[Array, "*batch N"]:
    """The part of `spd` the observer cannot see: XYZ of the result is zero.

    `spd - fundamental_metamer(spd)`; adding it to any spectrum leaves XYZ unchanged.
    """
    wl, s = _promote(wavelengths, spd)
    return s - fundamental_metamer(wl, s)


def metameric_black_basis(wavelengths: Float[Array, " N"]) -> Float[Array, "N N-3"]:
    """An orthonormal basis of the metameric blacks on `wavelengths` (null space of XYZ).

    **Returns:** `(N, N - 3)` columns `b` with `spectrum_to_xyz(wavelengths, b.T) == 0`
    (to rounding). Spectra that differ by any combination of them are metamers.
    """
    wl = _check_wavelengths(wavelengths)
    if wl.shape[0] <= 3:
        raise ValueError("`wavelengths` needs more than 3 samples to have metameric blacks")
    _, _, vt = jnp.linalg.svd(_cmf_matrix(wl), full_matrices=True)
    return vt[3:].T


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
    wl, s = _promote(wavelengths, spd)
    p = _spectrum(perturbation, wl, "perturbation").astype(wl.dtype)
    black = metameric_black(wl, p)
    if not keep_nonnegative:
        return s + black
    negative = black < 0
    room = jnp.where(negative, jnp.maximum(s, 0.0) / jnp.where(negative, -black, 1.0), jnp.inf)
    t = jnp.minimum(1.0, jnp.min(room, axis=-1, keepdims=True))
    return s + t * black


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
    _promote(wavelengths, spd_a, "spd_a")
    _promote(wavelengths, spd_b, "spd_b")
    rtol = finite_float(rtol, "rtol")
    rtol = value_error_if(rtol, rtol < 0, "`rtol` must be >= 0")
    xyz_a = spectrum_to_xyz(wavelengths, spd_a)
    xyz_b = spectrum_to_xyz(wavelengths, spd_b)
    scale = jnp.maximum(jnp.maximum(jnp.abs(xyz_a), jnp.abs(xyz_b)).max(axis=-1), 1e-300)
    return jnp.max(jnp.abs(xyz_a - xyz_b), axis=-1) <= rtol * scale
