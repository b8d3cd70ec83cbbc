"""gfxlab.brdf: the properties of a BRDF (domain, range, reciprocity, energy) and the shader."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from jax.test_util import check_grads

from gfxlab import brdf
from gfxlab.fit import fit

UP = np.array([0.0, 0.0, 1.0])
KEY = jax.random.key(0)

# Energy-conserving, reciprocal models with a range of parameters.
MODELS = {
    "lambert": brdf.Lambert(0.7),
    "phong": brdf.Phong(ks=0.6, shininess=30.0, kd=0.3),
    "phong_broad": brdf.Phong(ks=1.0, shininess=1.0),
    "blinn_phong": brdf.BlinnPhong(ks=0.5, shininess=50.0, kd=0.4),
    "blinn_phong_broad": brdf.BlinnPhong(ks=1.0, shininess=2.0),
    "ggx_smooth": brdf.CookTorrance(roughness=0.2, f0=1.0),
    "ggx_rough": brdf.CookTorrance(roughness=0.8, f0=1.0),
    "ggx_plastic": brdf.CookTorrance(roughness=0.4, f0=0.04, kd=0.9),
}
ORIGINAL_PHONG = brdf.Phong(ks=0.5, shininess=10.0, normalized=False)


def directions(count, seed, *, hemisphere=True):
    """Random unit vectors (uniform on the sphere, or its upper half)."""
    v = np.random.default_rng(seed).normal(size=(count, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    if hemisphere:
        v[:, 2] = np.abs(v[:, 2])
    return v


def at_angle(degrees):
    t = np.radians(degrees)
    return np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=-1)


# --------------------------------------------------------------------------- the three properties


@pytest.mark.parametrize("name", MODELS)
def test_reciprocal(name):
    model = MODELS[name]
    assert float(brdf.reciprocity_error(model, key=KEY)) < 1e-6
    normals = directions(256, 1, hemisphere=False)
    # directions in the hemisphere of arbitrary normals
    wi, wo = directions(256, 2, hemisphere=False), directions(256, 3, hemisphere=False)
    wi *= np.sign(np.sum(wi * normals, -1, keepdims=True))
    wo *= np.sign(np.sum(wo * normals, -1, keepdims=True))
    assert float(brdf.reciprocity_error(model, wi, wo, normals)) < 1e-6


def test_original_phong_is_not_reciprocal():
    error = float(brdf.reciprocity_error(ORIGINAL_PHONG, key=KEY))
    assert error > 0.1
    # the asymmetry is exactly the 1 / cos(theta_i) factor
    wi, wo = at_angle(20.0), np.array([-np.sin(np.radians(50.0)), 0, np.cos(np.radians(50.0))])
    ratio = ORIGINAL_PHONG(wi, wo, UP) / ORIGINAL_PHONG(wo, wi, UP)
    assert float(ratio) == pytest.approx(np.cos(np.radians(50.0)) / np.cos(np.radians(20.0)))


@pytest.mark.parametrize("name", [*MODELS, "original_phong"])
def test_range_and_domain(name):
    model = MODELS.get(name, ORIGINAL_PHONG)
    wi, wo = directions(2000, 4, hemisphere=False), directions(2000, 5, hemisphere=False)
    values = np.asarray(model(wi, wo, np.broadcast_to(UP, wi.shape)))
    assert np.all(np.isfinite(values)) and np.all(values >= 0)
    outside = (wi[:, 2] <= 0) | (wo[:, 2] <= 0)
    assert np.all(values[outside] == 0) and np.any(values[~outside] > 0)


# --------------------------------------------------------------------------- energy


ANGLES = at_angle(np.array([0.0, 20.0, 45.0, 70.0, 85.0]))


@pytest.mark.parametrize("name", MODELS)
def test_directional_albedo_at_most_one(name):
    albedo = np.asarray(brdf.directional_albedo(MODELS[name], ANGLES))
    assert np.all(albedo <= 1.0 + 1e-3) and np.all(albedo > 0)


def test_lambert_albedo_is_its_albedo():
    for a in (0.2, 1.0):
        values = brdf.directional_albedo(brdf.Lambert(a), ANGLES)
        np.testing.assert_allclose(np.asarray(values), a, atol=1e-3)


def test_analytic_albedos_at_normal_incidence():
    for s in (1.0, 20.0, 300.0):
        # normalised Phong and exactly normalised Blinn-Phong reflect ks at normal incidence
        phong = brdf.directional_albedo(brdf.Phong(0.8, s), UP)
        assert float(phong) == pytest.approx(0.8, abs=1e-4)
        blinn = brdf.directional_albedo(brdf.BlinnPhong(0.8, s), UP)
        assert float(blinn) == pytest.approx(0.8, abs=1e-4)
        # original Phong: ks * integral cos^s = ks 2 pi / (s + 1), above 1 for broad lobes
        original = brdf.directional_albedo(brdf.Phong(1.0, s, normalized=False), UP)
        assert float(original) == pytest.approx(2 * np.pi / (s + 1), rel=1e-4)


def _ggx_albedo_monte_carlo(roughness, theta_o, count=400_000, seed=0):
    """Independent estimate with f0 = 1: sample microfacet normals from D(h) cos(h)
    and weight by G2 (wo . h) / (cos_o cos_h), with Smith's Lambda in tangent form."""
    rng = np.random.default_rng(seed)
    alpha = roughness**2
    u1, u2 = rng.random(count), rng.random(count)
    tan2_h = alpha**2 * u1 / (1.0 - u1)
    cos_h = 1.0 / np.sqrt(1.0 + tan2_h)
    sin_h = np.sqrt(1.0 - cos_h**2)
    phi = 2 * np.pi * u2
    h = np.stack([sin_h * np.cos(phi), sin_h * np.sin(phi), cos_h], -1)
    wo = np.array([np.sin(theta_o), 0.0, np.cos(theta_o)])
    o_h = h @ wo
    wi = 2 * o_h[:, None] * h - wo
    cos_i, cos_o = wi[:, 2], wo[2]

    def lam(c):
        c = np.clip(c, 1e-12, 1.0)
        return 0.5 * (-1.0 + np.sqrt(1.0 + alpha**2 * (1.0 - c**2) / c**2))

    ok = (cos_i > 0) & (o_h > 0)
    g2 = np.where(ok, 1.0 / (1.0 + lam(cos_i) + lam(cos_o)), 0.0)
    weight = g2 * np.abs(o_h) / (cos_o * cos_h)
    return weight.mean(), weight.std() / np.sqrt(count)


@pytest.mark.parametrize("roughness, degrees", [(0.3, 0.0), (0.6, 45.0), (1.0, 0.0), (1.0, 70.0)])
def test_ggx_albedo_matches_independent_monte_carlo(roughness, degrees):
    ours = float(brdf.directional_albedo(brdf.CookTorrance(roughness, 1.0), at_angle(degrees)))
    mc, sigma = _ggx_albedo_monte_carlo(roughness, np.radians(degrees))
    assert abs(ours - mc) < 4 * sigma + 1e-3


def test_ggx_loses_energy_at_high_roughness():
    smooth = float(brdf.directional_albedo(brdf.CookTorrance(0.1, 1.0), UP))
    rough = float(brdf.directional_albedo(brdf.CookTorrance(1.0, 1.0), UP))
    assert smooth > 0.999 and rough < 0.5


# --------------------------------------------------------------------------- formulas


def test_cook_torrance_matches_textbook_formula():
    wi, wo = directions(300, 6), directions(300, 7)
    roughness, f0 = 0.45, 0.3
    alpha = roughness**2
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    cos_h, cos_i, cos_o = h[:, 2], wi[:, 2], wo[:, 2]
    d = alpha**2 / (np.pi * (cos_h**2 * (alpha**2 - 1) + 1) ** 2)

    def lam(c):
        return 0.5 * (-1.0 + np.sqrt(1.0 + alpha**2 * (1.0 / c**2 - 1.0)))

    g = 1.0 / (1.0 + lam(cos_i) + lam(cos_o))
    f = f0 + (1 - f0) * (1 - np.sum(wi * h, -1)) ** 5
    expected = d * g * f / (4 * cos_i * cos_o)
    ours = brdf.cook_torrance(wi, wo, UP, roughness=roughness, f0=f0)
    np.testing.assert_allclose(np.asarray(ours), expected, rtol=1e-10)


def test_models_match_their_formulas(maybe_jit):
    wi, wo = directions(100, 8), directions(100, 9)
    r = 2 * wi[:, 2:] * UP - wi
    cos_a = np.clip(np.sum(r * wo, -1), 0, None)
    h = (wi + wo) / np.linalg.norm(wi + wo, axis=-1, keepdims=True)
    s = 12.0
    phong = maybe_jit(functools.partial(brdf.phong, ks=0.5, shininess=s, kd=0.2))(wi, wo, UP)
    np.testing.assert_allclose(
        np.asarray(phong), 0.2 / np.pi + 0.5 * (s + 2) / (2 * np.pi) * cos_a**s, rtol=1e-12
    )
    original = brdf.phong(wi, wo, UP, ks=0.5, shininess=s, normalized=False)
    np.testing.assert_allclose(np.asarray(original), 0.5 * cos_a**s / wi[:, 2], rtol=1e-12)
    blinn = brdf.blinn_phong(wi, wo, UP, ks=0.5, shininess=s)
    norm = (s + 2) * (s + 4) / (8 * np.pi * (2 ** (-s / 2) + s))
    np.testing.assert_allclose(np.asarray(blinn), 0.5 * norm * h[:, 2] ** s, rtol=1e-12)
    lam = maybe_jit(brdf.lambert)(wi, wo, UP, albedo=0.3)
    np.testing.assert_allclose(np.asarray(lam), 0.3 / np.pi, rtol=1e-12)


@given(
    st.floats(0.0, np.pi / 2 - 1e-3),
    st.floats(0.0, np.pi / 2 - 1e-3),
    st.floats(0.0, 2 * np.pi),
    st.floats(0.0, 2 * np.pi),
)
def test_half_diff_round_trip(theta_h, theta_d, phi_d, phi_h):
    wi, wo = (np.asarray(v) for v in brdf.half_diff_to_directions(theta_h, theta_d, phi_d, phi_h))
    np.testing.assert_allclose([np.linalg.norm(wi), np.linalg.norm(wo)], 1.0, atol=1e-12)
    h = (wi + wo) / np.linalg.norm(wi + wo)
    expected_h = [np.sin(theta_h) * np.cos(phi_h), np.sin(theta_h) * np.sin(phi_h), np.cos(theta_h)]
    np.testing.assert_allclose(h, expected_h, atol=1e-9)
    assert np.arccos(np.clip(wi @ h, -1, 1)) == pytest.approx(theta_d, abs=1e-6)


# --------------------------------------------------------------------------- gradients


def _normalised(v):
    return v / jnp.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize(
    "fn, params",
    [
        (brdf.lambert, {"albedo": 0.6}),
        (functools.partial(brdf.phong, normalized=True), {"ks": 0.5, "shininess": 8.0, "kd": 0.3}),
        (functools.partial(brdf.phong, normalized=False), {"ks": 0.5, "shininess": 8.0, "kd": 0.3}),
        (brdf.blinn_phong, {"ks": 0.5, "shininess": 8.0, "kd": 0.3}),
        (brdf.cook_torrance, {"roughness": 0.5, "f0": 0.3, "kd": 0.2}),
    ],
)
def test_gradients(fn, params):
    wi = jnp.array([[0.3, 0.2, 0.9], [-0.5, 0.1, 0.6]])
    wo = jnp.array([[-0.2, -0.3, 0.8], [0.4, 0.2, 0.7]])

    def f(a, b, p):
        return fn(_normalised(a), _normalised(b), UP, **p)

    check_grads(jax.jit(f), (wi, wo, params), order=1, modes=["rev"], atol=1e-6, rtol=1e-6)
    # no NaN at normal incidence, at grazing angles, or below the horizon
    normal = jnp.array([0.0, 0.0, 1.0])
    grazing = jnp.array([1.0, 0.0, 0.0])
    below = jnp.array([0.0, 0.6, -0.8])
    a = jnp.stack([normal, grazing, normal, below])
    b = jnp.stack([normal, normal, grazing, normal])
    grads = jax.jit(jax.grad(lambda x, y, p: jnp.sum(fn(x, y, normal, **p)), argnums=(0, 1, 2)))(
        a, b, params
    )
    assert all(bool(jnp.all(jnp.isfinite(g))) for g in jax.tree_util.tree_leaves(grads))


def test_gradients_of_the_microfacet_terms():
    kw = dict(order=1, modes=["fwd", "rev"], atol=1e-6, rtol=1e-6)
    cos = jnp.array([0.2, 0.7, 0.95])
    check_grads(jax.jit(brdf.ggx_distribution), (cos, 0.4), **kw)
    check_grads(jax.jit(brdf.smith_visibility), (cos, cos[::-1], 0.4), **kw)
    check_grads(jax.jit(brdf.schlick_fresnel), (cos, 0.3), **kw)
    check_grads(
        jax.jit(brdf.reflect), (jnp.array([0.3, 0.4, 0.5]), jnp.array([0.0, 0.6, 0.8])), **kw
    )
    check_grads(
        jax.jit(lambda a, b, c: jnp.stack(brdf.half_diff_to_directions(a, b, c))),
        (0.3, 0.5, 1.0),
        **kw,
    )


def test_gradients_of_albedo_and_shader():
    check_grads(
        jax.jit(
            lambda r, f0: brdf.directional_albedo(
                brdf.CookTorrance(r, f0), at_angle(30.0), num_theta=32, num_phi=16
            )
        ),
        (0.5, 0.3),
        order=1,
        modes=["rev"],
    )
    check_grads(
        jax.jit(
            lambda s, light: brdf.shade_sphere(brdf.BlinnPhong(0.5, s, 0.3), (6, 7), light=light)
        ),
        (10.0, jnp.array([0.3, 0.5, 1.0])),
        order=1,
        modes=["rev"],
    )


def test_fit_recovers_ggx_parameters():
    theta_h, theta_d = np.meshgrid(np.linspace(0.0, 1.2, 9), np.linspace(0.0, 1.2, 9))
    wi, wo = brdf.half_diff_to_directions(theta_h.ravel(), theta_d.ravel(), 1.0)
    keep = (np.asarray(wi)[:, 2] > 0.05) & (np.asarray(wo)[:, 2] > 0.05)
    wi, wo = wi[keep], wo[keep]
    measured = brdf.cook_torrance(wi, wo, UP, roughness=0.35, f0=0.6)

    def residuals(params):
        model = brdf.CookTorrance(
            jnp.exp(params["log_roughness"]), jax.nn.sigmoid(params["logit_f0"])
        )
        return jnp.log1p(model(wi, wo, UP)) - jnp.log1p(measured)

    result = fit(residuals, {"log_roughness": jnp.log(0.7), "logit_f0": 0.0}, max_steps=40)
    assert float(jnp.exp(result.params["log_roughness"])) == pytest.approx(0.35, rel=1e-4)
    assert float(jax.nn.sigmoid(result.params["logit_f0"])) == pytest.approx(0.6, rel=1e-4)


# --------------------------------------------------------------------------- shader


def test_shade_sphere_lambert_is_n_dot_l():
    shape = (41, 31)
    image = np.asarray(brdf.shade_sphere(brdf.Lambert(0.5), shape, light=(0, 0, 2), intensity=3.0))
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    radius = 0.9 * 0.5 * min(shape)
    x = (cols - (shape[1] - 1) / 2) / radius
    y = ((shape[0] - 1 - rows) - (shape[0] - 1) / 2) / radius
    inside = x**2 + y**2 < 1
    expected = np.where(inside, 0.5 / np.pi * 3.0 * np.sqrt(np.clip(1 - x**2 - y**2, 0, 1)), 0)
    np.testing.assert_allclose(image, expected, atol=1e-12)


def test_shade_sphere_light_direction_follows_pixel_convention():
    right = np.asarray(brdf.shade_sphere(brdf.Lambert(1.0), (32, 32), light=(1, 0, 0.2)))
    assert right[:, 24:].sum() > 10 * right[:, :8].sum()
    up = np.asarray(brdf.shade_sphere(brdf.Lambert(1.0), (32, 32), light=(0, 1, 0.2)))
    assert up[:8].sum() > 10 * up[24:].sum()  # y up: the top rows are lit


def test_shade_sphere_point_light_falls_off_with_distance():
    near = brdf.shade_sphere(brdf.Lambert(1.0), (9, 9), light=(0, 0, 2), point_light=True)
    far = brdf.shade_sphere(brdf.Lambert(1.0), (9, 9), light=(0, 0, 3), point_light=True)
    # centre pixel: the surface point (0, 0, 1) is 1 and 2 units from the light
    assert float(near[4, 4] / far[4, 4]) == pytest.approx(4.0, rel=1e-9)


def test_shade_sphere_renders_every_model_and_a_colour_batch():
    for model in [*MODELS.values(), ORIGINAL_PHONG]:
        image = brdf.shade_sphere(model, (16, 16), light=(0.5, 0.5, 1.0), background=-1.0)
        assert image.shape == (16, 16) and bool(jnp.all(jnp.isfinite(image)))
        assert float(image[0, 0]) == -1.0
    rgb = jax.vmap(lambda f0: brdf.shade_sphere(brdf.CookTorrance(0.4, f0), (8, 8)))(
        jnp.array([0.9, 0.6, 0.3])
    )
    assert rgb.shape == (3, 8, 8) and bool(rgb[0, 4, 4] > rgb[2, 4, 4])


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: brdf.lambert(np.array([0, 0, 2.0]), UP, UP), "`wi` must contain unit vectors"),
        (lambda: brdf.phong(UP, np.array([0.1, 0, 1.0]), UP), "`wo` must contain unit vectors"),
        (lambda: brdf.blinn_phong(UP, UP, np.zeros(3)), "`n` must contain unit vectors"),
        (lambda: brdf.cook_torrance(UP, UP, UP, roughness=-0.1), "`roughness` must be >= 0"),
        (lambda: brdf.cook_torrance(UP, UP, UP, f0=1.5), r"`f0` must be in \[0, 1\]"),
        (lambda: brdf.lambert(UP, UP, UP, albedo=-0.5), "albedo"),
        (lambda: brdf.phong(UP, UP, UP, shininess=-1.0), "shininess"),
        (lambda: brdf.blinn_phong(UP, UP, UP, ks=-1.0), "ks"),
        (lambda: brdf.lambert(UP[:2], UP[:2], UP[:2]), r"shape \(\.\.\., 3\)"),
        (lambda: brdf.reciprocity_error(brdf.Lambert(), num_samples=0), "num_samples"),
        (lambda: brdf.directional_albedo(brdf.Lambert(), 2 * UP), "`wo` must contain unit"),
        (lambda: brdf.directional_albedo(brdf.Lambert(), UP, num_theta=1.5), "num_theta"),
        (lambda: brdf.shade_sphere(brdf.Lambert(), (0, 4)), "shape"),
        (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), light=(0, 0, 0)), "zero vector"),
        (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), light=(1, 0)), "light"),
        (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), radius=-1), "radius"),
        (lambda: brdf.reflect(UP[:2], UP), "`w` must have shape"),
        (lambda: brdf.half_diff_to_directions("x", 0.0, 0.0), "theta_h"),
        (lambda: brdf.ggx_distribution(1j, 0.5), "cos_h"),
        (lambda: brdf.smith_visibility(0.5, 0.5, object()), "alpha"),
        (lambda: brdf.schlick_fresnel(0.5, 2j), "f0"),
    ],
)
def test_bad_input_raises_clearly(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_bad_values_raise_under_jit():
    with pytest.raises(Exception, match="unit vectors"):
        jax.jit(brdf.lambert)(jnp.array([0.0, 0.0, 2.0]), UP, UP)
    with pytest.raises(Exception, match="roughness"):
        jax.jit(lambda r: brdf.cook_torrance(UP, UP, UP, roughness=r))(-1.0)
