"""gfxlab.color against colour-science, physics and Grassmann's laws."""

import subprocess
import sys
import warnings

import colour
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from colour.colorimetry import SDS_LEFS_PHOTOPIC, planck_law
from hypothesis import given
from hypothesis import strategies as st
from jax.test_util import check_grads
from scipy import integrate

from gfxlab import color

WL = color.CIE_WAVELENGTHS
CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
LEF = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]


def random_spectra(count, seed=0, n=WL.size):
    return np.random.default_rng(seed).uniform(0.0, 2.0, (count, n))


def colour_xyz(wavelengths, values, **kwargs):
    sd = colour.SpectralDistribution(values, wavelengths)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return colour.sd_to_XYZ(sd, **kwargs, method="Integration")


# --------------------------------------------------------------------------- tables


def test_import_is_light():
    code = (
        "import sys, gfxlab.color; "
        "bad = [m for m in ('colour', 'matplotlib', 'PIL') if m in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_tables_are_colour_sciences_exactly():
    np.testing.assert_array_equal(np.asarray(color.cmfs()), CMFS.values)
    np.testing.assert_array_equal(np.asarray(color.v_lambda()), LEF.values)
    wl, d65 = color.illuminant_d65()
    np.testing.assert_array_equal(np.asarray(wl), colour.SDS_ILLUMINANTS["D65"].wavelengths)
    np.testing.assert_array_equal(np.asarray(d65), colour.SDS_ILLUMINANTS["D65"].values)


def test_tables_on_the_grid_are_exact_and_never_import_colour():
    code = (
        "import sys, numpy as np; from gfxlab import color; "
        "wl = color.CIE_WAVELENGTHS; "
        "assert np.array_equal(np.asarray(color.cmfs(wl)), np.asarray(color.cmfs())); "
        "v = np.asarray(color.v_lambda()); "
        "assert np.array_equal(np.asarray(color.v_lambda(wl[::5])), v[::5]); "
        "color.spectrum_to_xyz(wl, wl * 0 + 1.0); color.illuminant_d65(); "
        "assert 'colour' not in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_interpolation_off_grid_and_zero_outside():
    wl = np.array([300.0, 359.5, 555.5, 600.25, 900.0])
    expected = np.stack([np.interp(wl, WL, CMFS.values[:, i], 0, 0) for i in range(3)], -1)
    np.testing.assert_allclose(np.asarray(color.cmfs(wl)), expected, rtol=1e-12, atol=0)
    assert float(color.v_lambda(wl)[0]) == 0.0 and float(color.v_lambda(wl)[-1]) == 0.0


# --------------------------------------------------------------------------- colorimetry


def test_spectrum_to_xyz_matches_colour_on_1nm_grid(maybe_jit):
    spectra = random_spectra(5)
    ours = np.asarray(maybe_jit(color.spectrum_to_xyz)(WL, spectra))
    for spd, xyz in zip(spectra, ours, strict=True):
        np.testing.assert_allclose(xyz, colour_xyz(WL, spd, cmfs=CMFS, k=683), rtol=1e-9)


def test_spectrum_to_xyz_with_illuminant_matches_colour():
    shape = colour.SpectralShape(360, 830, 1)
    illuminant = colour.sd_blackbody(2856, shape)
    reflectance = random_spectra(1, seed=1)[0] / 2
    ours = color.spectrum_to_xyz(WL, reflectance, illuminant=illuminant.values, k=None)
    ref = colour_xyz(WL, reflectance, cmfs=CMFS, illuminant=illuminant)
    np.testing.assert_allclose(np.asarray(ours), ref, rtol=1e-9)
    white = color.spectrum_to_xyz(WL, np.ones(WL.size), illuminant=illuminant.values, k=None)
    assert float(white[1]) == pytest.approx(100.0, rel=1e-12)


def test_spectrum_to_xyz_on_coarser_uniform_grid_matches_colour():
    shape = colour.SpectralShape(380, 780, 5)
    wl = shape.wavelengths
    spd = random_spectra(1, seed=2, n=wl.size)[0]
    ref = colour_xyz(wl, spd, cmfs=CMFS.copy().align(shape), k=683)
    np.testing.assert_allclose(np.asarray(color.spectrum_to_xyz(wl, spd)), ref, rtol=1e-9)


def test_spectrum_to_xyz_on_irregular_grid_converges():
    def smooth(wl):
        return 1.0 + np.exp(-(((wl - 520.0) / 40.0) ** 2)) + 0.5 * np.sin(wl / 37.0)

    rng = np.random.default_rng(3)
    wl = np.cumsum(rng.uniform(0.3, 0.7, 1200)) + 359.0
    wl = wl[wl <= 831.0]
    fine = color.spectrum_to_xyz(WL, smooth(WL))
    irregular = color.spectrum_to_xyz(wl, smooth(wl))
    np.testing.assert_allclose(np.asarray(irregular), np.asarray(fine), rtol=2e-3)


def test_d65_normalised_is_the_published_white():
    wl, d65 = color.illuminant_d65()
    xyz = color.spectrum_to_xyz(wl, jnp.ones_like(d65), illuminant=d65, k=None)
    # The published (95.047, 100, 108.883) comes from ASTM E308 weighting tables; plain
    # 5 nm summation of the 1 nm CMFs differs by 0.014 in Z (1.3e-4 relative).
    np.testing.assert_allclose(np.asarray(xyz), [95.047, 100.0, 108.883], atol=0.02)
    np.testing.assert_allclose(np.asarray(color.xyz_to_xy(xyz)), color.D65_XY, atol=1e-4)


def test_xy_conversions_match_colour():
    xyz = np.random.default_rng(4).uniform(0.01, 1.0, (20, 3))
    np.testing.assert_allclose(np.asarray(color.xyz_to_xy(xyz)), colour.XYZ_to_xy(xyz), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(color.xyz_to_xy(np.zeros(3))), color.D65_XY)
    xyy = colour.XYZ_to_xyY(xyz)
    back = color.xy_to_xyz(xyy[:, :2], xyy[:, 2])
    np.testing.assert_allclose(np.asarray(back), xyz, rtol=1e-12)


def test_spectral_locus_is_the_normalised_cmfs():
    locus = np.asarray(color.spectral_locus())
    np.testing.assert_allclose(locus, colour.XYZ_to_xy(CMFS.values), rtol=1e-12)
    assert locus.shape == (WL.size, 2)


@pytest.mark.parametrize("encode", [True, False])
def test_xyz_to_srgb_matches_colour(encode, maybe_jit):
    xyz = np.random.default_rng(5).uniform(-0.1, 1.2, (200, 3))
    ours = maybe_jit(color.xyz_to_srgb, static_argnames="encode")(xyz, encode=encode)
    ref = colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=encode)
    np.testing.assert_allclose(np.asarray(ours), ref, atol=1e-6, rtol=0)


def test_srgb_to_xyz_inverts_and_agrees_with_colour():
    rgb = np.random.default_rng(6).uniform(0.0, 1.0, (200, 3))
    xyz = color.srgb_to_xyz(rgb)
    np.testing.assert_allclose(np.asarray(color.xyz_to_srgb(xyz)), rgb, atol=1e-12)
    # colour-science uses IEC's rounded forward matrix, which is not exactly the inverse.
    np.testing.assert_allclose(np.asarray(xyz), colour.sRGB_to_XYZ(rgb), atol=1e-4)
    lin = color.srgb_to_xyz(rgb, encoded=False)
    np.testing.assert_allclose(np.asarray(color.xyz_to_srgb(lin, encode=False)), rgb, atol=1e-12)


@given(st.floats(-0.5, 2.0, allow_nan=False))
def test_srgb_transfer_function_round_trips_and_matches_colour(value):
    from colour.models import eotf_inverse_sRGB, eotf_sRGB

    encoded = float(color.srgb_encode(value))
    assert encoded == pytest.approx(float(eotf_inverse_sRGB(value)), abs=1e-12)
    assert float(color.srgb_decode(encoded)) == pytest.approx(value, abs=1e-12)
    assert float(color.srgb_decode(value)) == pytest.approx(float(eotf_sRGB(value)), abs=1e-12)


# --------------------------------------------------------------------------- photometry


def test_photometry_matches_colour():
    for spd in random_spectra(4, seed=7):
        sd = colour.SpectralDistribution(spd, WL)
        assert float(color.luminous_flux(WL, spd)) == pytest.approx(
            colour.luminous_flux(sd), rel=1e-9
        )
        assert float(color.luminous_efficiency(WL, spd)) == pytest.approx(
            colour.luminous_efficiency(sd), rel=1e-9
        )
        assert float(color.luminous_efficacy(WL, spd)) == pytest.approx(
            colour.luminous_efficacy(sd), rel=1e-9
        )
    batch = random_spectra(3, seed=8)
    np.testing.assert_allclose(
        np.asarray(color.luminous_flux(WL, batch)),
        [colour.luminous_flux(colour.SpectralDistribution(s, WL)) for s in batch],
        rtol=1e-9,
    )


def test_555nm_line_gives_683_lumens_per_watt():
    laser = color.line_spectrum(WL, 555.0, power=2.5)
    assert float(color.luminous_flux(WL, laser)) == pytest.approx(683.0 * 2.5, rel=1e-12)
    assert float(color.luminous_efficacy(WL, laser)) == pytest.approx(683.0, rel=1e-12)
    assert float(color.spectrum_to_xyz(WL, laser)[1]) == pytest.approx(683.0 * 2.5, rel=1e-12)
    sd = colour.SpectralDistribution(np.asarray(laser), WL)
    assert colour.luminous_efficacy(sd) == pytest.approx(683.0, rel=1e-12)
    # between samples: the efficacy is 683 V(l) with V interpolated linearly
    off = color.line_spectrum(WL, 600.3)
    expected = 683.0 * np.interp(600.3, WL, LEF.values)
    assert float(color.luminous_efficacy(WL, off)) == pytest.approx(expected, rel=1e-12)


def test_blackbody_matches_colour_and_stefan_boltzmann():
    for temperature in (1000.0, 2856.0, 6500.0):
        ours = np.asarray(color.planck(WL, temperature))
        np.testing.assert_allclose(ours, planck_law(WL * 1e-9, temperature) * 1e-9, rtol=1e-12)
        grid = np.geomspace(10.0, 1e7, 200_001)
        total = integrate.simpson(np.asarray(color.planck(grid, temperature)), x=grid)
        assert float(color.planck_total_radiance(temperature)) == pytest.approx(total, rel=1e-6)
    # Wien's displacement law, b = c2 / 4.965114...
    wl = np.linspace(900.0, 1100.0, 20001)
    peak = wl[np.argmax(np.asarray(color.planck(wl, 2856.0)))]
    assert peak == pytest.approx(1.4388e-2 / 4.965114231744276 / 2856.0 * 1e9, abs=0.02)
    batch = color.planck(WL, jnp.array([3000.0, 5000.0]))
    assert batch.shape == (2, WL.size)


def test_incandescent_and_equal_energy_efficacy():
    bulb = color.planck(WL, 2856.0)
    total = color.luminous_efficacy(WL, bulb, radiant_power=color.planck_total_radiance(2856.0))
    assert 15.0 < float(total) < 18.0  # a 2856 K blackbody: ~16 lm/W, most power is infrared
    flat = np.ones(WL.size)
    ref = colour.luminous_efficacy(colour.SpectralDistribution(flat, WL))
    assert float(color.luminous_efficacy(WL, flat)) == pytest.approx(ref, rel=1e-12)


def test_luminance_of_a_radiance_in_candela():
    radiance = color.line_spectrum(WL, 555.0, power=0.1)  # 0.1 W/(sr m^2) at 555 nm
    assert float(color.luminance(WL, radiance)) == pytest.approx(68.3, rel=1e-12)


# --------------------------------------------------------------------------- Grassmann, metamers


def test_grassmann_additivity_and_proportionality_on_1000_spectra():
    a, b = random_spectra(1000, seed=9), random_spectra(1000, seed=10)
    alpha = np.random.default_rng(11).uniform(0.1, 10.0, (1000, 1))
    xyz_a, xyz_b = color.spectrum_to_xyz(WL, a), color.spectrum_to_xyz(WL, b)
    np.testing.assert_allclose(
        np.asarray(color.spectrum_to_xyz(WL, a + b)), np.asarray(xyz_a + xyz_b), rtol=1e-12
    )
    np.testing.assert_allclose(
        np.asarray(color.spectrum_to_xyz(WL, alpha * a)), np.asarray(alpha * xyz_a), rtol=1e-12
    )


def test_grassmann_symmetry_transitivity_and_match_additivity():
    a, c, noise = random_spectra(3, seed=12)
    b = color.make_metamer(WL, a, noise)
    d = color.make_metamer(WL, c, noise[::-1])
    e = color.make_metamer(WL, b, np.roll(noise, 100))
    assert not np.allclose(np.asarray(a), np.asarray(b))
    assert bool(color.metameric_match(WL, a, b)) and bool(color.metameric_match(WL, b, a))
    assert bool(color.metameric_match(WL, b, e)) and bool(color.metameric_match(WL, a, e))
    assert bool(color.metameric_match(WL, a + c, b + d))
    assert bool(color.metameric_match(WL, a + d, b + c))
    assert bool(color.metameric_match(WL, 3.0 * a, 3.0 * b))
    assert not bool(color.metameric_match(WL, a, c))


def test_metamer_tools():
    spd = random_spectra(1, seed=13)[0]
    basis = color.metameric_black_basis(WL)
    assert basis.shape == (WL.size, WL.size - 3)
    np.testing.assert_allclose(np.asarray(basis.T @ basis), np.eye(WL.size - 3), atol=1e-12)
    scale = float(color.spectrum_to_xyz(WL, spd).max())
    assert float(jnp.abs(color.spectrum_to_xyz(WL, basis.T)).max()) < 1e-12 * scale
    fundamental = color.fundamental_metamer(WL, spd)
    np.testing.assert_allclose(
        np.asarray(color.fundamental_metamer(WL, fundamental)), np.asarray(fundamental), atol=1e-12
    )
    black = color.metameric_black(WL, spd)
    assert float(jnp.abs(color.spectrum_to_xyz(WL, black)).max()) < 1e-12 * scale
    bump = np.sin(WL / 9.0) * 5.0
    metamer = color.make_metamer(WL, spd, bump)
    assert float(metamer.min()) >= -1e-12
    np.testing.assert_allclose(
        np.asarray(color.spectrum_to_xyz(WL, metamer)),
        np.asarray(color.spectrum_to_xyz(WL, spd)),
        rtol=1e-12,
    )
    raw = color.make_metamer(WL, spd, bump, keep_nonnegative=False)
    assert float(raw.min()) < 0  # the full black would make the spectrum unphysical


def test_make_metamer_stays_nonnegative_in_float32():
    vis = np.arange(380.0, 781.0)
    d65_wl, d65 = color.illuminant_d65()
    d65_vis = np.interp(vis, np.asarray(d65_wl), np.asarray(d65))
    wiggle = 80 * np.sin(vis / 11.0) + 60 * np.cos(vis / 29.0)
    args = [jnp.asarray(a, jnp.float32) for a in (vis, d65_vis, wiggle)]
    for fn in (color.make_metamer, jax.jit(color.make_metamer)):
        meta = fn(*args)
        assert meta.dtype == jnp.float32 and float(meta.min()) >= 0.0
        assert float(jnp.max(jnp.abs(meta - args[1]))) > 0.3 * d65_vis.max()
        assert bool(color.metameric_match(vis, d65_vis, np.asarray(meta, float), rtol=1e-5))


# --------------------------------------------------------------------------- gradients


def test_gradients():
    wl = np.arange(380.0, 781.0, 5.0)  # a coarser grid keeps the finite differences cheap
    spd = jnp.asarray(random_spectra(1, seed=14, n=wl.size)[0])

    def check(fn, *args):
        # Jitted reverse mode: one program per derivative, checked against finite differences.
        check_grads(jax.jit(fn), args, modes=["rev"], order=1, atol=1e-6, rtol=1e-6)

    check(lambda s: color.spectrum_to_xyz(wl, s), spd)
    check(lambda s: color.luminous_flux(wl, s), spd)
    check(lambda s: color.luminous_efficacy(wl, s), spd)
    check(lambda s: color.luminous_efficiency(wl, s), spd)
    check(lambda s, p: color.make_metamer(wl, s, p), spd, spd[::-1])
    check(lambda t: color.planck(wl, t), jnp.array(2856.0))
    check(color.planck_total_radiance, jnp.array(2856.0))
    check(lambda p, c: color.line_spectrum(wl, c, p), 2.0, 555.3)
    xyz = jnp.array([[0.3, 0.4, 0.2], [0.2, 0.1, 0.15]])
    check(color.xyz_to_xy, xyz)
    check(color.xyz_to_srgb, xyz)
    check(color.srgb_to_xyz, jnp.array([0.5, 0.02, 0.9]))
    check(color.xy_to_xyz, jnp.array([0.3, 0.4]), 2.0)
    check(color.spectral_locus, jnp.array([450.5, 600.2]))
    # no NaN at the edges: black, the sRGB threshold, a cold body at short wavelengths
    for g in (
        jax.grad(lambda x: color.xyz_to_xy(x).sum())(jnp.zeros(3)),
        jax.grad(lambda x: color.srgb_encode(x))(0.0),
        jax.grad(lambda t: color.planck(WL, t).sum())(50.0),
    ):
        assert bool(jnp.all(jnp.isfinite(g)))


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: color.spectrum_to_xyz(WL[::-1], np.ones(WL.size)), "strictly increasing"),
        (lambda: color.spectrum_to_xyz(np.array([500.0, 500.0, 501.0]), np.ones(3)), "increasing"),
        (lambda: color.spectrum_to_xyz(WL, np.ones(10)), "to match `wavelengths`"),
        (lambda: color.spectrum_to_xyz(WL[None], np.ones(WL.size)), "1-D grid"),
        (lambda: color.spectrum_to_xyz(-WL[::-1], np.ones(WL.size)), "positive"),
        (lambda: color.spectrum_to_xyz(WL, np.ones(WL.size), illuminant=np.ones(3)), "illuminant"),
        (lambda: color.luminous_flux(np.array([1.0]), np.ones(1)), "at least 2"),
        (lambda: color.luminous_efficiency(WL, np.zeros(WL.size)), "positive total power"),
        (lambda: color.luminous_efficacy(WL, np.ones(WL.size), radiant_power=0.0), "positive"),
        (lambda: color.luminance(WL, np.ones(3)), "to match"),
        (lambda: color.planck(WL, -10.0), "temperature"),
        (lambda: color.planck(np.array([0.0, 500.0]), 3000.0), "positive"),
        (lambda: color.planck_total_radiance(0.0), "temperature"),
        (lambda: color.xyz_to_xy(np.ones(2)), r"shape \(\.\.\., 3\)"),
        (lambda: color.xy_to_xyz(np.array([0.3, 0.0])), "y > 0"),
        (lambda: color.xyz_to_srgb(np.ones(4)), "xyz"),
        (lambda: color.srgb_to_xyz(np.ones(2)), "rgb"),
        (lambda: color.line_spectrum(WL, 900.0), "inside"),
        (lambda: color.metameric_black_basis(np.array([400.0, 500.0, 600.0])), "more than 3"),
        (lambda: color.make_metamer(WL, np.ones(WL.size), np.ones(3)), "perturbation"),
        (lambda: color.fundamental_metamer(WL, np.ones(5)), "spd"),
        (lambda: color.metameric_black(WL[::-1], np.ones(WL.size)), "increasing"),
        (lambda: color.metameric_match(WL, np.ones(WL.size), np.ones(2)), "to match"),
        (lambda: color.cmfs(np.array([500.0, 400.0])), "increasing"),
        (lambda: color.v_lambda(np.array([[500.0]])), "1-D"),
        (lambda: color.spectral_locus(np.array([600.0, 500.0])), "increasing"),
        (lambda: color.srgb_encode(object()), "linear"),
        (lambda: color.srgb_decode(1j), "real"),
    ],
)
def test_bad_input_raises_clearly(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_bad_wavelengths_raise_under_jit():
    with pytest.raises(Exception, match="strictly increasing"):
        jax.jit(color.spectrum_to_xyz)(WL[::-1].copy(), jnp.ones(WL.size))
    with pytest.raises(Exception, match="temperature"):
        jax.jit(color.planck)(WL, -1.0)
