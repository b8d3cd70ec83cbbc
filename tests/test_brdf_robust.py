"""gfxlab.brdf at the edges: low roughness, bad input (eager and under jit), size limits."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from gfxlab import brdf

UP = np.array([0.0, 0.0, 1.0])


def _unit(v):
    return v / jnp.linalg.norm(v, axis=-1, keepdims=True)


def _pairs(dtype):
    """Light directions and views: the exact mirror direction, just off it, and far off."""
    wi = _unit(jnp.array([[0.3, 0.0, 1.0], [0.3, 0.1, 1.0], [0.5, 0.2, 0.8]], dtype))
    flip = jnp.array([-1.0, -1.0, 1.0], dtype)
    wo = jnp.stack(
        [
            wi[0] * flip,
            _unit(wi[1] * flip + jnp.array([0.0, 1e-3, 0.0], dtype)),
            _unit(jnp.array([-0.4, -0.2, 0.9], dtype)),
        ]
    )
    return wi, wo


def _naive_ggx(cos_h, alpha):
    """The textbook formula, in float64 NumPy (an independent reference)."""
    a2 = np.float64(alpha) ** 2
    c = np.float64(cos_h)
    return a2 / (np.pi * (c * c * (a2 - 1.0) + 1.0) ** 2)


# --------------------------------------------------------------------------- low roughness


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_ggx_is_finite_and_exact_at_the_mirror_down_to_the_minimum(dtype):
    alpha = jnp.asarray(brdf.MIN_ALPHA, dtype)
    d = brdf.ggx_distribution(jnp.asarray(1.0, dtype), alpha)
    assert d.dtype == dtype
    np.testing.assert_allclose(float(d), 1.0 / (np.pi * brdf.MIN_ALPHA**2), rtol=1e-6)
    cos = np.array([1.0, 0.99999, 0.9999, 0.999, 0.99, 0.9, 0.5, 0.1])
    for a in (brdf.MIN_ALPHA, 0.01, 0.3, 1.0):
        got = np.asarray(brdf.ggx_distribution(jnp.asarray(cos, dtype), jnp.asarray(a, dtype)))
        # float32 rounds cos itself (relative 6e-8), which moves D near a sharp peak.
        np.testing.assert_allclose(got, _naive_ggx(cos.astype(dtype), a), rtol=2e-5)


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_cook_torrance_values_and_gradients_finite_at_minimum_roughness(dtype):
    wi, wo = _pairs(dtype)
    n = jnp.asarray(UP, dtype)
    r = jnp.asarray(brdf.MIN_ROUGHNESS, dtype)
    values = brdf.cook_torrance(wi, wo, n, roughness=r, f0=0.5)
    assert values.dtype == dtype and bool(jnp.all(jnp.isfinite(values)))
    # At the mirror direction D = 1 / (pi alpha^2), V = 0.5 / (2 cos sqrt(a^2 + (1 - a^2) cos^2))
    # and F = f0 (cos_d = 1).
    cos = float(wi[0, 2])
    alpha2 = brdf.MIN_ALPHA**2
    expected = (
        1.0 / (np.pi * alpha2) * 0.5 / (2 * cos * np.sqrt(alpha2 + (1 - alpha2) * cos**2)) * 0.5
    )
    np.testing.assert_allclose(float(values[0]), expected, rtol=1e-5)

    def total(r, a, b, f0):
        return jnp.sum(brdf.cook_torrance(_unit(a), _unit(b), n, roughness=r, f0=f0))

    grads = jax.jit(jax.grad(total, argnums=(0, 1, 2, 3)))(r, wi, wo, jnp.asarray(0.5, dtype))
    assert all(bool(jnp.all(jnp.isfinite(g))) for g in grads)


@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_check_grads_down_to_the_minimum_roughness(dtype):
    wi, wo = _pairs(dtype)
    n = jnp.asarray(UP, dtype)
    margin = 1e-3 if dtype == jnp.float32 else 1e-5
    r = jnp.asarray(brdf.MIN_ROUGHNESS * (1 + 2 * margin), dtype)
    eps = brdf.MIN_ROUGHNESS * margin / 4  # steps stay above the minimum

    def f(r, a, b, f0):
        return brdf.cook_torrance(_unit(a), _unit(b), n, roughness=r, f0=f0, kd=0.2)

    args = (r, wi, wo, jnp.asarray(0.5, dtype))
    check_grads(jax.jit(f), args, order=1, modes=["rev"], eps=eps)
    model = lambda r, a, b: brdf.CookTorrance(r, 0.9)(_unit(a), _unit(b), n)
    if dtype == jnp.float64:
        check_grads(jax.jit(model), args[:3], order=1, modes=["rev"], eps=eps)
    else:
        # In float32 a finite difference cannot resolve the model's peak at the exact
        # mirror direction (in float64 too, the step float32 needs is 6e-4 off in
        # truncation alone; float32 rounding makes it 3e-3): its float32 gradients are
        # checked against the float64 ones, which check_grads checks in the float64 case.
        def grads(*xs):
            weights = jnp.arange(1.0, 4.0, dtype=xs[0].dtype)
            return jax.grad(lambda *v: jnp.sum(model(*v) * weights), argnums=(0, 1, 2))(*xs)

        ours = jax.jit(grads)(*args[:3])
        exact = jax.jit(grads)(*(x.astype(jnp.float64) for x in args[:3]))
        for g32, g64 in zip(ours, exact, strict=True):
            np.testing.assert_allclose(g32, g64, rtol=1e-3, atol=1e-3 * float(jnp.abs(g64).max()))
    # The microfacet terms alone, just above MIN_ALPHA. Away from the peak: in float32
    # the peak of D(cos_h) at MIN_ALPHA is narrower (1 - cos_h ~ alpha^2 / 2) than a
    # finite-difference step in cos_h can resolve.
    alpha = jnp.asarray(1.5 * brdf.MIN_ALPHA, dtype)
    cos = jnp.asarray([0.999, 0.99, 0.5], dtype)
    kw = dict(order=1, modes=["fwd", "rev"], eps=1e-5 if dtype == jnp.float32 else 1e-7)
    check_grads(jax.jit(brdf.ggx_distribution), (cos, alpha), **kw)
    check_grads(jax.jit(brdf.smith_visibility), (cos, cos[::-1], alpha), **kw)


@pytest.mark.parametrize("roughness", [0.0, 0.005, 0.012, brdf.MIN_ROUGHNESS * 0.99, -0.1])
def test_roughness_below_the_minimum_is_an_error(roughness, maybe_jit):
    with pytest.raises(Exception, match="`roughness` must be >= 0.02"):
        maybe_jit(lambda r: brdf.cook_torrance(UP, UP, UP, roughness=r))(roughness)
    with pytest.raises(ValueError, match="`roughness` must be >= 0.02 .*MIN_ROUGHNESS"):
        brdf.CookTorrance(roughness=roughness)


def test_alpha_below_the_minimum_is_an_error(maybe_jit):
    with pytest.raises(Exception, match="`alpha` must be >= .*MIN_ALPHA"):
        maybe_jit(brdf.ggx_distribution)(1.0, 0.0)
    with pytest.raises(Exception, match="`alpha` must be >= .*MIN_ALPHA"):
        maybe_jit(brdf.smith_visibility)(0.5, 0.0, 0.0)


def test_module_validation_keeps_fits_and_transforms_working():
    model = brdf.CookTorrance(jnp.float32(0.5), 0.5)
    assert model.roughness.dtype == jnp.float32
    # Traced fields are checked when the model is called, not at construction.
    value = jax.jit(lambda r: brdf.CookTorrance(r, 0.5)(UP, UP, UP))(0.3)
    assert np.isfinite(float(value))
    with pytest.raises(Exception, match="roughness"):
        jax.jit(lambda r: brdf.CookTorrance(r, 0.5)(UP, UP, UP))(0.0)
    grads = jax.grad(lambda m: m(UP, UP, UP))(model)
    assert np.isfinite(float(grads.roughness)) and np.isfinite(float(grads.f0))
    batched = jax.vmap(lambda r: brdf.CookTorrance(r)(UP, UP, UP))(jnp.array([0.2, 0.4]))
    assert batched.shape == (2,)


# --------------------------------------------------------------------------- bad input

NAN3 = np.array([np.nan, 0.0, 1.0])
INF3 = np.array([0.0, np.inf, 1.0])

BAD_CALLS = [
    # directions: None, NaN, inf, shape
    (lambda: brdf.lambert(None, UP, UP), TypeError, "`wi`"),
    (lambda: brdf.phong(UP, None, UP), TypeError, "`wo`"),
    (lambda: brdf.blinn_phong(UP, UP, None), TypeError, "`n`"),
    (lambda: brdf.cook_torrance(NAN3, UP, UP), ValueError, "`wi` must be finite"),
    (lambda: brdf.cook_torrance(UP, INF3, UP), ValueError, "`wo` must be finite"),
    (lambda: brdf.lambert(UP, UP, NAN3), ValueError, "`n` must be finite"),
    (lambda: brdf.cook_torrance(UP, UP, np.ones((2, 2))), ValueError, r"`n` must have shape"),
    (lambda: brdf.lambert(np.ones((2, 3)), np.ones((3, 3)), UP), ValueError, "`wi` .*`wo`"),
    (lambda: brdf.phong(np.tile(UP, (3, 1)), UP, UP, ks=np.ones(2)), ValueError, r"`ks` \(2,\)"),
    (lambda: brdf.ggx_distribution(np.ones(2), np.ones(3)), ValueError, "`cos_h`.*`alpha`"),
    (lambda: brdf.reflect(np.ones((2, 3)), np.ones((3, 3))), ValueError, "`w` .*`n`"),
    # parameters: None, NaN, inf, range
    (lambda: brdf.lambert(UP, UP, UP, albedo=None), TypeError, "`albedo`"),
    (lambda: brdf.phong(UP, UP, UP, ks=np.nan), ValueError, "`ks` must be finite"),
    (lambda: brdf.phong(UP, UP, UP, shininess=np.inf), ValueError, "`shininess` must be finite"),
    (lambda: brdf.phong(UP, UP, UP, normalized="yes"), TypeError, "`normalized`"),
    (lambda: brdf.blinn_phong(UP, UP, UP, kd=np.nan), ValueError, "`kd` must be finite"),
    (lambda: brdf.blinn_phong(UP, UP, UP, kd=1.5), ValueError, r"`kd` must be in \[0, 1\]"),
    (lambda: brdf.cook_torrance(UP, UP, UP, roughness=None), TypeError, "`roughness`"),
    (lambda: brdf.cook_torrance(UP, UP, UP, roughness=np.nan), ValueError, "`roughness` must be"),
    (lambda: brdf.cook_torrance(UP, UP, UP, f0=np.inf), ValueError, "`f0` must be finite"),
    (lambda: brdf.cook_torrance(UP, UP, UP, kd="x"), TypeError, "`kd`"),
    # microfacet terms
    (lambda: brdf.ggx_distribution(None, 0.5), TypeError, "`cos_h`"),
    (lambda: brdf.ggx_distribution(np.nan, 0.5), ValueError, "`cos_h` must be finite"),
    (lambda: brdf.ggx_distribution(1.0, np.inf), ValueError, "`alpha` must be finite"),
    (lambda: brdf.smith_visibility(np.nan, 0.5, 0.5), ValueError, "`cos_i` must be finite"),
    (lambda: brdf.smith_visibility(0.5, None, 0.5), TypeError, "`cos_o`"),
    (lambda: brdf.schlick_fresnel(np.inf, 0.5), ValueError, "`cos_d` must be finite"),
    (lambda: brdf.schlick_fresnel(0.5, np.nan), ValueError, "`f0` must be finite"),
    (lambda: brdf.schlick_fresnel(0.5, -0.5), ValueError, r"`f0` must be in \[0, 1\]"),
    (lambda: brdf.reflect(None, UP), TypeError, "`w`"),
    (lambda: brdf.reflect(UP, NAN3), ValueError, "`n` must be finite"),
    # modules, at construction
    (lambda: brdf.Lambert(None), TypeError, "`albedo`"),
    (lambda: brdf.Lambert(1.5), ValueError, r"`albedo` must be in \[0, 1\]"),
    (lambda: brdf.Phong(ks=np.nan), ValueError, "`ks` must be finite"),
    (lambda: brdf.Phong(normalized=None), TypeError, "`normalized`"),
    (lambda: brdf.BlinnPhong(shininess=-1.0), ValueError, "`shininess` must be >= 0"),
    (lambda: brdf.BlinnPhong(kd="abc"), TypeError, "`kd`"),
    (lambda: brdf.CookTorrance(roughness="abc"), TypeError, "`roughness`"),
    (lambda: brdf.CookTorrance(f0=np.inf), ValueError, "`f0` must be finite"),
    (lambda: brdf.CookTorrance(kd=2.0), ValueError, r"`kd` must be in \[0, 1\]"),
    # properties and the shader
    (lambda: brdf.reciprocity_error(None), TypeError, "`brdf`"),
    (lambda: brdf.reciprocity_error(brdf.Lambert(), NAN3, UP), ValueError, "`wi` must be finite"),
    (lambda: brdf.reciprocity_error(brdf.Lambert(), n=np.ones(2)), ValueError, "`n` must have"),
    (lambda: brdf.reciprocity_error(brdf.Lambert(), key=7), TypeError, "`key`"),
    (lambda: brdf.reciprocity_error(brdf.Lambert()), TypeError, "`key` must be a jax.random key"),
    (lambda: brdf.reciprocity_error(brdf.Lambert(), wi=UP), TypeError, "`key`"),
    (lambda: brdf.reciprocity_error(brdf.Lambert(), num_samples=10**9), ValueError, "num_samples"),
    (lambda: brdf.directional_albedo("lambert", UP), TypeError, "`brdf`"),
    (lambda: brdf.directional_albedo(brdf.Lambert(), None), TypeError, "`wo`"),
    (lambda: brdf.directional_albedo(brdf.Lambert(), NAN3), ValueError, "`wo` must be finite"),
    (lambda: brdf.directional_albedo(brdf.Lambert(), UP, INF3), ValueError, "`n` must be finite"),
    (lambda: brdf.directional_albedo(brdf.Lambert(), UP, num_phi=10**6), ValueError, "num_phi"),
    (lambda: brdf.shade_sphere(None, (4, 4)), TypeError, "`brdf`"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), None), ValueError, "`shape`"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (10**5, 10**5)), ValueError, "shape"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), light=NAN3), ValueError, "`light` must"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), light=None), TypeError, "`light`"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), radius=None), TypeError, "`radius`"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), radius=np.inf), ValueError, "`radius`"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), intensity=np.nan), ValueError, "intensity"),
    (lambda: brdf.shade_sphere(brdf.Lambert(), (4, 4), background=None), TypeError, "background"),
    (lambda: brdf.half_diff_to_directions(np.nan, 0.0, 0.0), ValueError, "`theta_h` must be"),
    (lambda: brdf.half_diff_to_directions(0.0, None, 0.0), TypeError, "`theta_d`"),
    (lambda: brdf.half_diff_to_directions(0.0, 0.0, np.inf), ValueError, "`phi_d` must be"),
    (lambda: brdf.half_diff_to_directions(0.0, 0.0, 0.0, None), TypeError, "`phi_h`"),
]


def test_reciprocity_error_draws_its_directions_from_the_key():
    phong = brdf.Phong(0.5, 10.0, normalized=False)  # not reciprocal: the value depends on them
    a = brdf.reciprocity_error(phong, key=jax.random.key(0), num_samples=64)
    b = brdf.reciprocity_error(phong, key=jax.random.key(1), num_samples=64)
    assert float(a) != float(b)
    assert float(brdf.reciprocity_error(phong, key=jax.random.key(0), num_samples=64)) == float(a)
    legacy = brdf.reciprocity_error(phong, key=jax.random.PRNGKey(0), num_samples=64)
    assert float(legacy) == float(a)
    # no key is needed when nothing is drawn
    wi, wo = _pairs(jnp.float64)
    ci, co = np.asarray(wi[:, 2]), np.asarray(wo[:, 2])  # f(wi, wo) / f(wo, wi) = co / ci
    expected = np.max(1.0 - np.minimum(ci, co) / np.maximum(ci, co))
    assert float(brdf.reciprocity_error(phong, wi, wo)) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("call, error, message", BAD_CALLS)
def test_bad_input_names_the_argument(call, error, message):
    with pytest.raises(error, match=message):
        call()


@pytest.mark.parametrize(
    "fn, args, message",
    [
        (lambda wi: brdf.lambert(wi, UP, UP), (NAN3,), "`wi` must be finite"),
        (lambda n: brdf.cook_torrance(UP, UP, n), (INF3,), "`n` must be finite"),
        (lambda r: brdf.cook_torrance(UP, UP, UP, roughness=r), (np.nan,), "`roughness` must"),
        (lambda s: brdf.phong(UP, UP, UP, shininess=s), (np.inf,), "`shininess` must be finite"),
        (lambda f0: brdf.schlick_fresnel(0.5, f0), (np.nan,), "`f0` must be finite"),
        (lambda c: brdf.ggx_distribution(c, 0.5), (np.nan,), "`cos_h` must be finite"),
        (lambda t: brdf.half_diff_to_directions(t, 0.0, 0.0)[0], (np.nan,), "`theta_h` must"),
        (lambda light: brdf.shade_sphere(brdf.Lambert(), (3, 3), light=light), (NAN3,), "light"),
    ],
)
def test_bad_values_raise_under_jit_naming_the_argument(fn, args, message):
    with pytest.raises(Exception, match=message):
        jax.block_until_ready(jax.jit(fn)(*args))
