"""gfxlab.color: every public function names the right argument for None, NaN and inf,
eagerly and under jit."""

import jax
import numpy as np
import pytest

from gfxlab import color

WL = np.linspace(400.0, 700.0, 31)
FLAT = np.ones(31)
NAN_SPD = np.where(np.arange(31) == 5, np.nan, 1.0)
INF_SPD = np.where(np.arange(31) == 7, np.inf, 1.0)
NAN3 = np.array([0.2, np.nan, 0.3])

CASES = [
    (lambda: color.luminance(WL, None), TypeError, "`radiance`"),
    (lambda: color.luminance(WL, NAN_SPD), ValueError, "`radiance` must be finite"),
    (lambda: color.luminance(WL, np.ones(5)), ValueError, "`radiance` must have shape"),
    (lambda: color.luminous_flux(WL, INF_SPD), ValueError, "`spd` must be finite"),
    (lambda: color.luminous_flux(WL, FLAT, k_m=np.nan), ValueError, "`k_m` must be finite"),
    (lambda: color.luminous_efficiency(None, FLAT), TypeError, "`wavelengths`"),
    (lambda: color.luminous_efficiency(WL, NAN_SPD), ValueError, "`spd` must be finite"),
    (
        lambda: color.luminous_efficacy(WL, FLAT, radiant_power=np.inf),
        ValueError,
        "`radiant_power` must be finite",
    ),
    (lambda: color.spectrum_to_xyz(WL, NAN_SPD), ValueError, "`spd` must be finite"),
    (
        lambda: color.spectrum_to_xyz(WL, FLAT, illuminant=INF_SPD),
        ValueError,
        "`illuminant` must be finite",
    ),
    (lambda: color.cmfs(np.array([400.0, np.nan])), ValueError, "`wavelengths` must be finite"),
    (lambda: color.v_lambda(np.array([[400.0, 500.0]])), ValueError, "`wavelengths` must be"),
    (lambda: color.xyz_to_xy(None), TypeError, "`xyz`"),
    (lambda: color.xyz_to_xy(NAN3), ValueError, "`xyz` must be finite"),
    (lambda: color.xy_to_xyz(np.array([0.3, np.inf])), ValueError, "`xy` must be finite"),
    (lambda: color.xy_to_xyz(np.array([0.3, 0.3]), np.nan), ValueError, "`luminance` must be"),
    (lambda: color.srgb_encode(np.nan), ValueError, "`linear` must be finite"),
    (lambda: color.srgb_decode(None), TypeError, "`encoded`"),
    (lambda: color.xyz_to_srgb(NAN3), ValueError, "`xyz` must be finite"),
    (lambda: color.srgb_to_xyz(NAN3), ValueError, "`rgb` must be finite"),
    (lambda: color.planck(WL, np.nan), ValueError, "`temperature` must be finite"),
    (lambda: color.planck(WL, -5.0), ValueError, "`temperature` must be positive"),
    (lambda: color.planck(None, 5000.0), TypeError, "`wavelengths`"),
    (lambda: color.planck_total_radiance(np.inf), ValueError, "`temperature` must be finite"),
    (lambda: color.line_spectrum(WL, np.nan), ValueError, "`line_wavelength` must be finite"),
    (lambda: color.line_spectrum(WL, 500.0, None), TypeError, "`power`"),
    (lambda: color.fundamental_metamer(WL, NAN_SPD), ValueError, "`spd` must be finite"),
    (lambda: color.metameric_black(WL, None), TypeError, "`spd`"),
    (lambda: color.metameric_black_basis(np.array([1.0])), ValueError, "`wavelengths`"),
    (lambda: color.make_metamer(WL, FLAT, NAN_SPD), ValueError, "`perturbation` must be finite"),
    (lambda: color.metameric_match(WL, FLAT, NAN_SPD), ValueError, "`spd_b` must be finite"),
    (lambda: color.metameric_match(WL, None, FLAT), TypeError, "`spd_a`"),
    (lambda: color.metameric_match(WL, FLAT, FLAT, rtol=-1.0), ValueError, "`rtol` must be"),
    (lambda: color.spectral_locus(np.array([500.0, 400.0])), ValueError, "increasing"),
    (lambda: color.spectrum_to_xyz(WL, FLAT, k=np.nan), ValueError, "`k` must be finite"),
    (lambda: color.spectrum_to_xyz(WL, FLAT, k="x"), TypeError, "`k`"),
    # k=None normalises by the white's Y, which is 0 outside the observer's range
    (lambda: color.spectrum_to_xyz([900.0, 950.0], [1.0, 1.0], k=None), ValueError, "`k=None`"),
    (lambda: color.xyz_to_xy(np.full(3, 0.2), black_xy=None), TypeError, "`black_xy`"),
    (lambda: color.xyz_to_xy(np.full(3, 0.2), black_xy=(0.3, np.nan)), ValueError, "`black_xy`"),
    (lambda: color.xy_to_xyz(np.ones((4, 2)) / 3, np.ones(3)), ValueError, "`luminance` must"),
    (lambda: color.xyz_to_srgb(np.full(3, 0.2), encode="yes"), TypeError, "`encode`"),
    (lambda: color.srgb_to_xyz(np.full(3, 0.2), encoded=None), TypeError, "`encoded`"),
    (lambda: color.make_metamer(WL, FLAT, FLAT, keep_nonnegative=1), TypeError, "keep_nonneg"),
    (lambda: color.line_spectrum(WL, 500.0, np.ones(3)), ValueError, "`power` must have shape"),
    (lambda: color.metameric_match(WL, FLAT, FLAT, rtol=[1.0, 2.0]), ValueError, "`rtol`"),
]


@pytest.mark.parametrize("call, error, message", CASES)
def test_bad_input_names_the_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


@pytest.mark.parametrize(
    "fn, args, message",
    [
        (lambda s: color.luminance(WL, s), (NAN_SPD,), "`radiance` must be finite"),
        (lambda s: color.spectrum_to_xyz(WL, s), (INF_SPD,), "`spd` must be finite"),
        (color.xyz_to_srgb, (NAN3,), "`xyz` must be finite"),
        (lambda t: color.planck(WL, t), (np.nan,), "`temperature` must be finite"),
        (lambda w: color.v_lambda(w), (np.array([400.0, np.nan]),), "`wavelengths` must be"),
    ],
)
def test_bad_values_raise_under_jit(fn, args, message):
    with pytest.raises(Exception, match=message):
        jax.block_until_ready(jax.jit(fn)(*args))


def test_luminance_is_luminous_flux_of_the_radiance():
    radiance = color.planck(WL, 3000.0)
    np.testing.assert_allclose(
        color.luminance(WL, radiance), color.luminous_flux(WL, radiance), rtol=1e-15
    )
