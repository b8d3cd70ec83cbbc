"""gfxlab.fit: every method reaches the least-squares optimum that numpy computes."""

import warnings

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


@pytest.mark.parametrize("chunk_size", [None, 5])
def test_gauss_newton_stepping_off_an_exact_solution_is_convergence(chunk_size):
    """The Jacobian of `(p - 3)**2` vanishes at the solution, so Gauss-Newton's next step
    is 0 / 0: the fit stops at the exact solution instead of reporting a NaN objective."""
    start = np.zeros(5, np.float32)  # float32 reaches p == 3 exactly
    result = fit(lambda p: (p - 3.0) ** 2, start, method="gauss_newton", chunk_size=chunk_size)
    assert result.converged and result.loss == 0.0
    assert np.isfinite(np.asarray(result.loss_history)).all()
    assert result.num_steps == len(result.loss_history) - 1 < 100
    np.testing.assert_array_equal(result.params, 3.0)


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


def test_a_check_inside_fn_failing_midway_is_a_fit_error_naming_it():
    """Gauss-Newton on a B-spline whose control points all coincide, with its knots
    fitted: the knots' Jacobian is zero, the undamped step is NaN and the curve's own
    finiteness check fails inside the compiled steps. `fit` says so (its message, the
    steps, a damped method to try), not equinox's runtime traceback."""
    from gfxlab.curves import BSpline

    u = jnp.linspace(0, 1, 20)
    target = jnp.stack([jnp.cos(3 * u), jnp.sin(3 * u)], -1)
    start = BSpline(jnp.zeros((6, 2)), 3, fit_knots=True)
    with pytest.raises(
        FitError,
        match=r"steps 1-5 of the 'gauss_newton' fit: `control_points` "
        r"must be finite.*levenberg_marquardt",
    ) as caught:
        fit(lambda c: c(u) - target, start, method="gauss_newton", max_steps=5)
    assert "EQX_ON_ERROR" not in str(caught.value)
    damped = fit(lambda c: c(u) - target, start, method="levenberg_marquardt", max_steps=5)
    assert damped.loss < damped.loss_history[0]


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


# --- a driver, not traceable: a clear error under transformations ------------------------


@pytest.mark.parametrize("transform", [jax.jit, jax.grad, jax.vmap])
def test_fit_under_a_transformation_says_it_is_a_driver(transform):
    def outer(start):
        return jnp.sum(fit(lambda p: p - 1.0, start, max_steps=3).params)

    start = jnp.ones(2) if transform is not jax.vmap else jnp.ones((2, 2))
    with pytest.raises(TypeError, match="`fit` is a driver"):
        transform(outer)(start)

    # The traced value captured by `fn` (a closure), not passed in `params` or `args`.
    def captured(scale):
        return jnp.sum(fit(lambda p: p - scale, jnp.zeros(2), max_steps=3).params)

    scale = jnp.ones(2) if transform is jax.vmap else jnp.asarray(1.0)
    with pytest.raises(TypeError, match="`fit` is a driver"):
        transform(captured)(scale)


def test_a_python_branch_on_the_parameters_keeps_jaxs_own_error():
    """A mistake inside `fn` (a Python `if` on a traced parameter) is not reported as a
    call under a transformation."""
    with pytest.raises(FitError, match="calling `fn` with the initial parameters failed"):
        fit(lambda p: p - 1.0 if p[0] > 0 else p, jnp.ones(2), max_steps=3)


# --- argument checks -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"rtol": -1.0}, FitError, "`rtol` must be a finite number >= 0"),
        ({"rtol": float("nan")}, FitError, "`rtol` must be a finite number"),
        ({"atol": "x"}, TypeError, "`atol` must be a number"),
        ({"learning_rate": 0.0}, FitError, "`learning_rate` must be a finite number > 0"),
        ({"learning_rate": float("inf")}, FitError, "`learning_rate` must be a finite"),
        ({"learning_rate": None}, TypeError, "`learning_rate` must be a number"),
        ({"chunk_size": 0}, FitError, "`chunk_size` must be >= 1"),
        ({"chunk_size": 2.5}, TypeError, "`chunk_size` must be an int"),
        ({"max_steps": None}, TypeError, "`max_steps` must be an int"),
        ({"max_steps": 10**12}, FitError, "`max_steps` must be <= 10000000"),
        ({"method": 3}, TypeError, "`method` must be one of"),
        ({"method": "Adam"}, FitError, "`method` must be one of"),
        ({"progress": "yes"}, TypeError, "`progress` must be True or False"),
        ({"bounds": {"a": (1.0, 0.0)}}, FitError, "`bounds` of `params` leaf 0 must have lo < hi"),
        ({"bounds": {"a": (1.0, 2.0)}}, FitError, "starts outside its open `bounds`"),
        ({"bounds": {"b": (1.0, 2.0)}}, FitError, "`bounds` must be a pytree prefix of `params`"),
        ({"fixed": {"a": "yes"}}, TypeError, "`fixed` must hold True/False"),
        ({"fixed": {"a": True}}, FitError, "no floating-point arrays to fit"),
    ],
)
def test_bad_settings_are_named(kwargs, error, message):
    with pytest.raises(error, match=message):
        fit(lambda p: p["a"] - 1.0, {"a": jnp.zeros(2)}, **kwargs)


def test_bad_fn_and_params():
    with pytest.raises(TypeError, match="`fn` must be callable"):
        fit(None, jnp.zeros(2))
    with pytest.raises(TypeError, match="`params` must be a pytree of arrays to fit, got None"):
        fit(lambda p: p, None)
    with pytest.raises(FitError, match="holds NaN or inf at the start"):
        fit(lambda p: p, jnp.array([0.0, jnp.nan]))
    with pytest.raises(FitError, match="`fn` must return an array"):
        fit(lambda p: "loss", jnp.zeros(2))
    with pytest.raises(FitError, match="calling `fn` with the initial parameters failed"):
        fit(lambda p: p @ jnp.ones(3), jnp.zeros(2))


# --- one meaning for scalars (a loss) and vectors (residuals) --------------------------


@pytest.mark.parametrize("method", ["bfgs", "adam", "gradient_descent"])
def test_scalar_loss_and_residuals_mean_the_same_for_minimisers(method):
    def resid(model, x, y):
        return model(x) - y

    def loss(model, x, y):
        return jnp.sum(resid(model, x, y) ** 2)

    kw = {"args": (X, Y), "method": method, "max_steps": 60, "learning_rate": 0.02}
    a = fit(resid, Quadratic(jnp.zeros(3)), **kw)
    b = fit(loss, Quadratic(jnp.zeros(3)), **kw)
    np.testing.assert_allclose(a.loss_history, b.loss_history, rtol=1e-9)
    np.testing.assert_allclose(a.params.coeffs, b.params.coeffs, rtol=1e-7, atol=1e-10)
    # and the history is sum(r^2) of the iterates (checked on the returned best one)
    r = np.asarray(Quadratic(a.params.coeffs)(X) - Y)
    np.testing.assert_allclose(a.loss, np.sum(r**2), rtol=1e-10)


def test_default_method_follows_the_output():
    assert fit(residuals, Quadratic(jnp.zeros(3)), args=(X, Y)).method == "levenberg_marquardt"
    scalar = fit(
        lambda m, x, y: jnp.sum(residuals(m, x, y) ** 2), Quadratic(jnp.zeros(3)), args=(X, Y)
    )
    assert scalar.method == "bfgs"
    np.testing.assert_allclose(scalar.params.coeffs, OPTIMUM, atol=1e-6)
    # a one-element vector is a residual vector: its square is the loss
    one = fit(lambda p: jnp.atleast_1d(p - 2.0), jnp.asarray(0.0), method="gauss_newton")
    np.testing.assert_allclose(one.params, 2.0, atol=1e-9)


# --- the compiled step is cached -------------------------------------------------------


@pytest.mark.parametrize("method", ["levenberg_marquardt", "bfgs", "adam"])
def test_refitting_the_same_function_does_not_retrace(method):
    traces = []

    def resid(p, x, y):
        traces.append(1)  # runs only while JAX traces `resid`
        return p[0] * x + p[1] - y

    x = jnp.linspace(0, 1, 8)
    first = fit(resid, jnp.zeros(2), args=(x, 2 * x + 1), method=method, max_steps=30)
    count = len(traces)
    second = fit(resid, jnp.ones(2), args=(x, 3 * x - 1), method=method, max_steps=30)
    assert len(traces) == count  # new data, same shapes: no new trace
    if method != "adam":
        np.testing.assert_allclose(first.params, [2, 1], atol=1e-6)
        np.testing.assert_allclose(second.params, [3, -1], atol=1e-6)
    fit(resid, jnp.zeros(2), args=(x[:4], x[:4]), method=method, max_steps=30)
    assert len(traces) > count  # a new shape compiles again


# --- bounds ----------------------------------------------------------------------------


def test_bounds_keep_the_parameter_inside_instead_of_clipping():
    seen = []

    def resid(p):
        jax.debug.callback(lambda q: seen.append(float(q)), p["quality"])
        return jnp.atleast_1d(p["quality"] - 150.0)  # the optimum lies outside

    for method in ["levenberg_marquardt", "adam"]:
        seen.clear()
        result = fit(
            resid,
            {"quality": 50.0},
            bounds={"quality": (1.0, 100.0)},
            method=method,
            max_steps=400,
            learning_rate=0.5,
        )
        q = float(result.params["quality"])
        assert 99.0 < q < 100.0, method
        assert seen and all(1.0 < v < 100.0 for v in seen)


def test_one_sided_and_array_bounds():
    result = fit(
        lambda p: p + 3.0,  # wants -3
        jnp.array([1.0, 2.0]),
        bounds=(jnp.array([0.0, -jnp.inf]), None),
        max_steps=200,
    )
    assert 0 < result.params[0] < 1e-3
    np.testing.assert_allclose(result.params[1], -3.0, atol=1e-8)
    upper = fit(lambda p: p - 5.0, jnp.array([-1.0]), bounds=(None, 2.0), max_steps=200)
    assert 1.99 < float(upper.params[0]) < 2.0


def test_bounded_start_round_trips_exactly():
    start = {"a": jnp.array([1.5, 99.0, 42.0]), "b": jnp.array(0.25)}
    result = fit(
        lambda p: jnp.zeros(3) * p["a"] + 0.0 * p["b"],
        start,
        bounds={"a": (1.0, 100.0), "b": (0.0, None)},
        method="adam",
        max_steps=2,
    )
    np.testing.assert_allclose(result.params["a"], start["a"], rtol=1e-12)
    np.testing.assert_allclose(result.params["b"], start["b"], rtol=1e-12)


# --- fixed leaves and the fixed_fields protocol ----------------------------------------


class Spline(eqx.Module):
    """A small Module with the protocol: knots fixed unless `fit_knots`."""

    knots: jax.Array
    weights: jax.Array
    fit_knots: bool = eqx.field(static=True, default=False)

    def fixed_fields(self):
        return () if self.fit_knots else ("knots",)

    def __call__(self, x):
        return jnp.sum(self.weights * jnp.exp(-((x[:, None] - self.knots) ** 2)), axis=-1)


@pytest.mark.parametrize("method", ["levenberg_marquardt", "gauss_newton", "bfgs", "adam"])
def test_fixed_fields_protocol_holds_knots(method):
    truth = Spline(jnp.array([-0.5, 0.0, 0.5]), jnp.array([1.0, -2.0, 0.5]))
    x = jnp.linspace(-1, 1, 30)
    target = truth(x)
    start = Spline(jnp.array([-0.4, 0.1, 0.6]), jnp.zeros(3))
    result = fit(lambda m: m(x) - target, start, method=method, max_steps=50, learning_rate=0.1)
    np.testing.assert_array_equal(result.params.knots, start.knots)
    assert result.loss < result.loss_history[0]
    moving = fit(
        lambda m: m(x) - target,
        Spline(start.knots, jnp.zeros(3), fit_knots=True),
        method="levenberg_marquardt",
        max_steps=50,
    )
    assert not np.array_equal(moving.params.knots, start.knots)


def test_fixed_fields_protocol_nested_and_misnamed():
    class Bad(eqx.Module):
        w: jax.Array

        def fixed_fields(self):
            return ("knots",)

    with pytest.raises(FitError, match=r"`Bad.fixed_fields\(\)` names \['knots'\]"):
        fit(lambda m: m.w, Bad(jnp.ones(2)))
    spline = Spline(jnp.array([0.0, 1.0]), jnp.ones(2))
    result = fit(lambda p: p["s"].weights + p["s"].knots + p["c"], {"s": spline, "c": jnp.ones(2)})
    np.testing.assert_array_equal(result.params["s"].knots, spline.knots)
    np.testing.assert_allclose(
        result.params["s"].weights + result.params["c"], -spline.knots, atol=1e-8
    )


def test_fixed_argument_prefix_and_callable():
    start = {"a": jnp.array([1.0, 2.0]), "b": jnp.array(3.0)}
    by_prefix = fit(lambda p: p["a"] + p["b"], start, fixed={"a": True, "b": False})
    np.testing.assert_array_equal(by_prefix.params["a"], start["a"])
    np.testing.assert_allclose(by_prefix.params["b"], -1.5, atol=1e-8)
    by_callable = fit(lambda p: p["a"] + p["b"], start, fixed=lambda leaf: leaf.ndim == 0)
    np.testing.assert_array_equal(by_callable.params["b"], 3.0)
    np.testing.assert_allclose(by_callable.params["a"], [-3.0, -3.0], atol=1e-8)


# --- the best iterate is returned ------------------------------------------------------


def test_best_iterate_is_returned_when_the_fit_overshoots():
    # Adam with a large rate oscillates around the minimum of p^2: the last iterate is
    # worse than the best one.
    result = fit(
        lambda p: jnp.sum(p**2), jnp.array([1.0]), method="adam", learning_rate=0.3, max_steps=25
    )
    history = np.asarray(result.loss_history)
    assert result.final_loss > result.loss
    assert result.loss == history.min()
    assert result.best_step == int(np.argmin(history))
    np.testing.assert_allclose(np.sum(np.asarray(result.params) ** 2), result.loss, rtol=1e-12)


def test_start_is_returned_when_nothing_improves():
    with pytest.warns(RuntimeWarning, match="every step made the loss worse"):
        result = fit(
            lambda p: jnp.sum(p**2),
            jnp.array([1.0]),
            method="gradient_descent",
            learning_rate=1.5,
            max_steps=5,
        )  # each step doubles |p|
    assert result.best_step == 0
    np.testing.assert_array_equal(result.params, [1.0])
    assert result.final_loss > result.loss == 1.0


def test_a_forward_mode_method_on_a_reverse_mode_only_function_is_a_clear_error():
    """A `fn` with a custom VJP (like `gfxlab.render.render`) has no forward-mode
    derivative: Levenberg-Marquardt names the methods that work, and BFGS fits it."""

    @jax.custom_vjp
    def wave(x):
        return jnp.sin(x)

    wave.defvjp(lambda x: (jnp.sin(x), x), lambda x, g: (g * jnp.cos(x),))
    with pytest.raises(FitError, match="forward mode.*'adam' or 'bfgs'"):
        fit(lambda p: wave(p) - 0.5, jnp.zeros(2))
    result = fit(lambda p: jnp.sum((wave(p) - 0.5) ** 2), jnp.zeros(2), method="bfgs")
    np.testing.assert_allclose(result.params, np.arcsin(0.5), atol=1e-6)


def test_integer_outputs_and_mixed_float_dtypes_are_clear_errors():
    with pytest.raises(FitError, match="`fn` must return floating-point residuals"):
        fit(lambda p: jnp.array([1, 2]), jnp.array(0.0))
    # float32 parameters against float64 data (x64 on): Levenberg-Marquardt cannot mix them
    with pytest.raises(FitError, match="different float dtypes"):
        fit(lambda p, y: p - y, jnp.zeros(3, jnp.float32), args=(jnp.ones(3),))
    result = fit(lambda p, y: p - y, jnp.zeros(3), args=(jnp.ones(3),))  # one dtype: fine
    np.testing.assert_allclose(result.params, 1.0)


def test_a_negative_loss_that_improves_does_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = fit(
            lambda p: jnp.sum((p - 1.0) ** 2) - 10.0, jnp.zeros(2), method="adam", max_steps=20
        )
    assert result.loss < float(result.loss_history[0]) - 0.5 and result.best_step > 0
