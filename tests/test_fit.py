"""gfxlab.fit: every method reaches the least-squares optimum that numpy computes."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax
import optimistix as optx
import pytest

from gfxlab.fit import METHODS, FitError, fit

rng = np.random.default_rng(0)
X = jnp.asarray(rng.uniform(-1, 1, 40))
Y = jnp.asarray(1.5 * X**2 - 0.5 * X + 0.25 + 0.01 * rng.normal(size=40))
DESIGN_MATRIX = np.stack([np.asarray(X) ** 2, np.asarray(X), np.ones(40)], axis=1)
OPTIMUM = np.linalg.lstsq(DESIGN_MATRIX, np.asarray(Y), rcond=None)[0]


class Quadratic(eqx.Module):
    coeffs: jax.Array
    label: str = eqx.field(static=True, default="q")

    def __call__(self, x):
        return self.coeffs[0] * x**2 + self.coeffs[1] * x + self.coeffs[2]


def residuals(model, x, y):
    return model(x) - y


@pytest.mark.parametrize(
    ("method", "steps", "rate", "tol"),
    [
        ("levenberg_marquardt", 50, None, 1e-9),
        ("gauss_newton", 20, None, 1e-9),
        ("bfgs", 100, None, 1e-6),
        ("adam", 3000, 0.05, 1e-3),
        ("gradient_descent", 3000, 0.01, 1e-3),
    ],
)
def test_methods_reach_the_linear_least_squares_optimum(method, steps, rate, tol):
    result = fit(
        residuals,
        Quadratic(jnp.zeros(3)),
        args=(X, Y),
        method=method,
        max_steps=steps,
        learning_rate=rate or 0.01,
    )
    np.testing.assert_allclose(result.params.coeffs, OPTIMUM, atol=tol)
    assert result.loss_history.shape == (result.num_steps + 1,)
    assert result.loss_history[-1] < result.loss_history[0]
    expected_loss = np.sum((DESIGN_MATRIX @ np.asarray(result.params.coeffs) - np.asarray(Y)) ** 2)
    np.testing.assert_allclose(result.loss, expected_loss, rtol=1e-9)
    assert result.params.label == "q"
    if METHODS[method] or method == "bfgs":
        assert result.converged and result.num_steps < steps


def test_scalar_loss_with_minimisers_and_dict_params():
    result = fit(
        lambda p: (p["a"] - 3.0) ** 2 + (p["b"] + 1.0) ** 4,
        {"a": 0.0, "b": 0.0},
        method="bfgs",
        max_steps=200,
    )
    np.testing.assert_allclose(result.params["a"], 3.0, atol=1e-6)
    np.testing.assert_allclose(result.params["b"], -1.0, atol=3e-2)


def test_custom_solver_and_optax_transformation():
    r1 = fit(
        residuals,
        Quadratic(jnp.zeros(3)),
        args=(X, Y),
        method=optx.Dogleg(rtol=1e-10, atol=1e-12),
        max_steps=50,
    )
    np.testing.assert_allclose(r1.params.coeffs, OPTIMUM, atol=1e-8)
    r2 = fit(
        residuals, Quadratic(jnp.zeros(3)), args=(X, Y), method=optax.adam(0.05), max_steps=2000
    )
    np.testing.assert_allclose(r2.params.coeffs, OPTIMUM, atol=1e-3)


def test_progress_and_chunks_give_the_same_result(capsys):
    whole = fit(residuals, Quadratic(jnp.zeros(3)), args=(X, Y), method="adam", max_steps=200)
    chunked = fit(
        residuals,
        Quadratic(jnp.zeros(3)),
        args=(X, Y),
        method="adam",
        max_steps=200,
        progress=True,
        chunk_size=30,
    )
    np.testing.assert_allclose(whole.loss_history, chunked.loss_history, rtol=1e-12)
    assert "step 200/200" in capsys.readouterr().out


def test_non_float_leaves_are_held_fixed():
    result = fit(
        lambda p: jnp.atleast_1d(p["w"] * p["n"] - 6.0), {"w": jnp.zeros(()), "n": 3}, max_steps=20
    )
    assert result.params["n"] == 3
    np.testing.assert_allclose(result.params["w"], 2.0, atol=1e-9)


def test_nan_residual_raises_naming_the_step():
    with pytest.raises(FitError, match="NaN or inf at step"):
        fit(
            lambda p: jnp.log(p - 1.0),
            jnp.array([2.0, 3.0]),
            method="gradient_descent",
            learning_rate=10.0,
            max_steps=10,
        )
    with pytest.raises(FitError, match="step 0"):
        fit(lambda p: jnp.sqrt(p), jnp.array([-1.0]))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "newton"}, "method"),
        ({"max_steps": 0}, "max_steps"),
        ({"args": [1]}, "args"),
    ],
)
def test_bad_arguments(kwargs, message):
    with pytest.raises(FitError, match=message):
        fit(lambda p, *a: p - 1.0, jnp.zeros(2), **kwargs)


def test_least_squares_needs_residuals_not_a_scalar():
    with pytest.raises(FitError, match="residuals"):
        fit(lambda p: jnp.sum(p**2), jnp.ones(2), method="gauss_newton")


def test_no_float_parameters():
    with pytest.raises(FitError, match="no floating-point"):
        fit(lambda p: p["n"] - 1.0, {"n": 3})
