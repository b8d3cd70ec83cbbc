"""The CIE tables (observer, V(lambda), D65), their interpolation, and the argument
checks shared by `gfxlab.color`.

Every public function checks shapes and types in Python (`_grid`, `_spectrum`) and
does everything that touches array values (NaN/inf, ranges, the computation itself)
in one `checked_jit`ted function, so an eager call is one compiled call.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import as_float, check_finite, checked_jit, value_error_if
from .._resources import data_file

#: Maximum luminous efficacy of photopic vision, lm/W (the SI definition of the candela
#: fixes 683 lm/W at 540 THz, about 555 nm).
K_M = 683.0

#: The observer tables' grid: 360..830 nm in 1 nm steps (a NumPy array).
CIE_WAVELENGTHS = np.arange(360.0, 831.0)

#: Chromaticity of CIE illuminant D65 (2-degree observer), the sRGB white point.
D65_XY = (0.3127, 0.3290)

#: Chromaticities of the sRGB (ITU-R BT.709) red, green and blue primaries.
SRGB_PRIMARIES_XY = ((0.64, 0.33), (0.30, 0.60), (0.15, 0.06))


# --------------------------------------------------------------------------- tables


@functools.cache
def _tables() -> dict[str, np.ndarray]:
    """The observer and D65 tables as float64 NumPy arrays, read once from the shipped
    `data/color/*.csv` (generated from colour-science by `data/color/make_tables.py`)."""
    obs = np.loadtxt(data_file("color", "cie_observer.csv"), delimiter=",", skiprows=1)
    ill = np.loadtxt(data_file("color", "cie_d65.csv"), delimiter=",", skiprows=1)
    if not np.array_equal(obs[:, 0], CIE_WAVELENGTHS):
        raise ValueError("data/color/cie_observer.csv is not on the 360..830 nm 1 nm grid")
    return {"cmfs": obs[:, 1:4], "v": obs[:, 4], "d65_wavelengths": ill[:, 0], "d65": ill[:, 1]}


def _table_at(wl: jax.Array, values: np.ndarray) -> jax.Array:
    """Rows of a table on `CIE_WAVELENGTHS` at `wl`: linear in between, exactly the
    tabulated rows on the grid, zero outside 360..830 nm (traceable)."""
    table = jnp.asarray(values, wl.dtype)
    last = values.shape[0] - 1
    pos = wl - float(CIE_WAVELENGTHS[0])  # a Python float keeps the dtype of `wl`
    index = jnp.clip(jnp.floor(pos), 0, last - 1).astype(jnp.int32)
    t = pos - index
    inside = (pos >= 0) & (pos <= last)
    if table.ndim == 2:
        t, inside = t[..., None], inside[..., None]
    # (1 - t) a + t b is exactly a at t = 0 and exactly b at t = 1 (the 830 nm row).
    return jnp.where(inside, (1.0 - t) * table[index] + t * table[index + 1], 0.0)


def _cmfs_at(wl: jax.Array) -> jax.Array:
    return _table_at(wl, _tables()["cmfs"])


def _v_at(wl: jax.Array) -> jax.Array:
    return _table_at(wl, _tables()["v"])


# --------------------------------------------------------------------------- checks


def _grid(wavelengths, name: str = "wavelengths") -> jax.Array:
    """Static checks of a wavelength grid: a float array of shape `(N,)`, `N >= 2`."""
    wl = as_float(wavelengths, name)
    if wl.ndim != 1 or wl.shape[0] < 2:
        raise ValueError(
            f"`{name}` must be a 1-D grid of at least 2 wavelengths in nm, got shape "
            f"{tuple(wl.shape)}"
        )
    return wl


def _check_grid(wl: jax.Array, name: str = "wavelengths") -> jax.Array:
    """Value checks of a grid (inside the jitted function): finite, positive, increasing."""
    wl = check_finite(wl, name)
    wl = value_error_if(wl, wl[0] <= 0, f"`{name}` must be positive (nanometres)")
    return value_error_if(
        wl, jnp.any(jnp.diff(wl) <= 0), f"`{name}` must be strictly increasing (nanometres)"
    )


def _spectrum(spd, size: int, name: str = "spd") -> jax.Array:
    """Static checks of spectra sampled on a grid of `size` wavelengths: `(..., size)`."""
    s = as_float(spd, name)
    if s.ndim == 0 or s.shape[-1] != size:
        raise ValueError(
            f"`{name}` must have shape (..., {size}) to match `wavelengths`, got shape "
            f"{tuple(s.shape)}"
        )
    return s


def _cell_widths(wl: jax.Array) -> jax.Array:
    """Summation weights: the width of the cell around each sample.

    Interior samples get half the distance between their neighbours, the two end
    samples a full step, so a uniform grid gets its interval everywhere (CIE 15).
    """
    gaps = jnp.diff(wl)
    inner = 0.5 * (gaps[1:] + gaps[:-1])
    return jnp.concatenate([gaps[:1], inner, gaps[-1:]])


# --------------------------------------------------------------------------- public


@checked_jit
def _cmfs(wl):
    return _cmfs_at(_check_grid(wl))


@checked_jit
def _v_lambda(wl):
    return _v_at(_check_grid(wl))


def cmfs(wavelengths=None) -> Float[Array, "N 3"]:
    """The CIE 1931 2-degree colour-matching functions xbar, ybar, zbar.

    **Arguments:**

    - `wavelengths`: `(N,)` increasing wavelengths in nm (default: `CIE_WAVELENGTHS`,
      where the tabulated values are returned exactly).

    **Returns:** `(N, 3)` values, linearly interpolated, zero outside 360..830 nm.
    """
    if wavelengths is None:
        return jnp.asarray(_tables()["cmfs"])
    return _cmfs(_grid(wavelengths))


def v_lambda(wavelengths=None) -> Float[Array, " N"]:
    """The CIE 1924 photopic luminous efficiency function V(lambda) (peak 1 at 555 nm).

    **Arguments:**

    - `wavelengths`: `(N,)` increasing wavelengths in nm (default `CIE_WAVELENGTHS`).

    **Returns:** `(N,)` values, linearly interpolated, zero outside 360..830 nm.
    """
    if wavelengths is None:
        return jnp.asarray(_tables()["v"])
    return _v_lambda(_grid(wavelengths))


def illuminant_d65() -> tuple[Float[Array, " M"], Float[Array, " M"]]:
    """CIE standard illuminant D65 as tabulated (300..780 nm, 5 nm; 100 at 560 nm).

    **Returns:** `(wavelengths, relative_spd)`.
    """
    t = _tables()
    return jnp.asarray(t["d65_wavelengths"]), jnp.asarray(t["d65"])
