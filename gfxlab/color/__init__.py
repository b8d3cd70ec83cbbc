"""Colorimetry and photometry: CMFs, V(lambda), XYZ, sRGB, luminance, luminous flux.

One package, one flat namespace: `_tables` (the CIE tables and the shared checks),
`_spectra` (spectra to XYZ, photometry, blackbody and line spectra), `_spaces`
(chromaticity and sRGB), `_metamers` (metamers and metameric blacks).

Spectra are sampled on an increasing wavelength grid in nanometres: `wavelengths`
of shape `(N,)` and a spectral power distribution `spd` of shape `(..., N)` (a batch
of spectra shares one grid). The observer tables (CIE 1931 2-degree colour-matching
functions xbar, ybar, zbar and the CIE 1924 photopic luminous efficiency function
V(lambda), 360..830 nm at 1 nm) come from colour-science through the generated
table `data/color/cie_observer.csv`, shipped with the package and read on first use
(colour-science itself is never imported). Off the 1 nm grid the tables are
interpolated linearly, and they are zero outside 360..830 nm.

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

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab import color
    >>> wl = color.CIE_WAVELENGTHS
    >>> laser = color.line_spectrum(wl, 555.0, power=1.0)  # 1 W at 555 nm
    >>> round(float(color.luminous_efficacy(wl, laser)), 6)  # 683 lm/W
    683.0
"""

from ._metamers import (
    fundamental_metamer,
    make_metamer,
    metameric_black,
    metameric_black_basis,
    metameric_match,
)
from ._spaces import (
    spectral_locus,
    srgb_decode,
    srgb_encode,
    srgb_to_xyz,
    xy_to_xyz,
    xyz_to_srgb,
    xyz_to_xy,
)
from ._spectra import (
    line_spectrum,
    luminance,
    luminous_efficacy,
    luminous_efficiency,
    luminous_flux,
    planck,
    planck_total_radiance,
    spectrum_to_xyz,
)
from ._tables import (
    CIE_WAVELENGTHS,
    D65_XY,
    K_M,
    SRGB_PRIMARIES_XY,
    cmfs,
    illuminant_d65,
    v_lambda,
)

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
