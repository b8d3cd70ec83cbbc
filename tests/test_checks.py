"""gfxlab._checks: every check gives the same message eagerly and under jit."""

import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from gfxlab import _checks as C

# JAX reports an exception raised while a compiled program runs as JaxRuntimeError or,
# on some dispatch paths, as ValueError; either carries the check's message.
JIT_ERRORS = (jax.errors.JaxRuntimeError, ValueError)


NAN = float("nan")
INF = float("inf")

# (check applied to one traced array, a bad input, the expected message)
VALUE_CHECKS = [
    (lambda x: C.check_finite(x, "x"), [1.0, NAN], "`x` must be finite (no NaN or inf)"),
    (lambda x: C.check_finite(x, "x"), [INF], "`x` must be finite (no NaN or inf)"),
    (lambda x: C.finite_float(x, "weights"), [-INF], "`weights` must be finite (no NaN or inf)"),
    (lambda x: C.value_error_if(x, x < 0, "`x` must be >= 0"), [-1.0], "`x` must be >= 0"),
    (lambda x: C.check_range(x, "q", minimum=1, maximum=100), [0.5], "`q` must be in [1, 100]"),
    (lambda x: C.check_range(x, "q", minimum=1, maximum=100), [NAN], "`q` must be in [1, 100]"),
    (
        lambda x: C.check_range(x, "u", minimum=0, maximum=1, upper_open=True),
        [1.0],
        "`u` must be in [0, 1)",
    ),
    (lambda x: C.check_range(x, "t", maximum=2), [3.0], "`t` must be <= 2 and not NaN"),
    (lambda x: C.check_range(x, "t", minimum=0), [NAN], "`t` must be >= 0 and not NaN"),
    (
        lambda x: C.check_range(x, "t", minimum=0, maximum=2, finite=True, what="a bound"),
        [-INF],
        "`t` must be in [0, 2] (a bound)",
    ),
    (lambda x: C.positive(x, "sigma"), [0.0], "`sigma` must be finite and > 0"),
    (lambda x: C.positive(x, "sigma"), [INF], "`sigma` must be finite and > 0"),
    (lambda x: C.positive(x, "sigma", "in pixels^2"), [NAN], "`sigma` must be finite and > 0 ("),
    (
        lambda x: C.check_range(x, "s", maximum=2, finite=True),
        [-INF],
        "`s` must be finite and <= 2",
    ),
    (
        lambda x: C.check_rect(x, "window"),
        [0.0, 0.0, -1.0, 1.0],
        "`window` must be (xmin, ymin, xmax, ymax) with xmax > xmin and ymax > ymin "
        "(a rectangle with positive width and height)",
    ),
    (lambda x: C.check_rect(x, "window"), [0.0, 0.0, NAN, 1.0], "`window` must be finite"),
]
IDS = [f"{i}-{m[:20]}" for i, (_, _, m) in enumerate(VALUE_CHECKS)]


@pytest.mark.parametrize(("check", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_eager(check, bad, message):
    with pytest.raises(ValueError) as info:
        check(jnp.asarray(bad))
    assert str(info.value).startswith(message)
    assert C.check_message(info.value) == str(info.value)


@pytest.mark.parametrize(("check", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_under_jax_jit(check, bad, message):
    """JAX wraps the error in JaxRuntimeError; the message is in it, recoverable."""
    with pytest.raises(JIT_ERRORS) as info:
        jax.jit(check)(jnp.asarray(bad))
    assert C.check_message(info.value).startswith(message)
    assert message.split(" (")[0] in str(info.value)


@pytest.mark.parametrize(("check", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_under_checked_jit_and_filter_jit(check, bad, message):
    with pytest.raises(ValueError) as info:
        C.checked_jit(check)(jnp.asarray(bad))
    assert str(info.value).startswith(message)
    with pytest.raises(eqx.EquinoxRuntimeError) as info2:
        eqx.filter_jit(check)(jnp.asarray(bad))
    assert C.check_message(info2.value) == str(info.value)


@pytest.mark.parametrize(("check", "bad", "message"), VALUE_CHECKS[:4], ids=IDS[:4])
def test_value_checks_under_vmap(check, bad, message):
    good = jnp.ones((3, len(bad)))
    np.testing.assert_array_equal(jax.vmap(check)(good), good)
    with pytest.raises(Exception) as info:
        jax.vmap(check)(jnp.stack([jnp.ones(len(bad)), jnp.asarray(bad)]))
    assert C.check_message(info.value).startswith(message)


@pytest.mark.parametrize(("check", "bad", "message"), VALUE_CHECKS, ids=IDS)
def test_value_checks_pass_good_values_and_gradients(check, bad, message):
    good = jnp.asarray([1.0, 0.0, 2.0, 3.0]) if len(bad) == 4 else jnp.full(len(bad), 1.5)
    if "[0, 1)" in message:
        good = good / 3
    np.testing.assert_array_equal(check(good), good)
    np.testing.assert_array_equal(jax.jit(check)(good), good)
    check_grads(lambda x: jnp.sum(check(x) ** 2), (good,), order=1, modes=["rev"])


def test_checked_jit_lets_other_errors_through_and_takes_jit_options():
    @C.checked_jit(static_argnames="n")
    def tile(x, n):
        return jnp.tile(C.check_finite(x, "x"), n)

    assert tile(jnp.ones(2), n=3).shape == (6,)
    with pytest.raises(ValueError, match="^`x` must be finite"):
        tile(jnp.array([NAN]), n=2)
    with pytest.raises(TypeError):
        C.checked_jit(lambda x: x + "a")(1.0)


def test_check_message_of_other_errors_is_none():
    assert C.check_message(RuntimeError("boom")) is None
    assert C.check_message(KeyError("k")) is None


@pytest.mark.parametrize(
    ("value", "kwargs", "error", "message"),
    [
        (None, {}, TypeError, "`n` must be an int, got None"),
        ("3", {}, TypeError, "`n` must be an int"),
        (2.5, {}, TypeError, "`n` must be an int"),
        (INF, {}, TypeError, "`n` must be an int"),
        (NAN, {}, TypeError, "`n` must be an int"),
        (True, {}, TypeError, "`n` must be an int"),
        (0, {"minimum": 1}, ValueError, "`n` must be >= 1"),
        (10**30, {"maximum": 1000}, ValueError, r"`n` must be <= 1000 \(a documented size"),
    ],
)
def test_static_int_rejects(value, kwargs, error, message):
    with pytest.raises(error, match=message):
        C.static_int(value, "n", **kwargs)


def test_static_int_accepts_integral_values_and_refuses_tracers():
    assert C.static_int(4.0, "n") == 4
    assert C.static_int(np.int64(5), "n", minimum=5, maximum=5) == 5
    assert C.static_int(jnp.asarray(6), "n") == 6
    with pytest.raises(TypeError, match="`n` sets an array size"):
        jax.jit(lambda n: C.static_int(n, "n"))(3)


def test_static_shape_and_allocation_limit():
    assert C.static_shape((4, 5, 3)) == (4, 5)
    with pytest.raises(ValueError, match=r"`shape\[0\]` must be >= 1"):
        C.static_shape((0, 5))
    with pytest.raises(ValueError, match="`size` asks for"):
        C.static_shape((2**20, 2**20), "size")
    with pytest.raises(ValueError, match="`shape` must be an image shape"):
        C.static_shape("ab")
    # an array of sizes, as `np.array(image.shape)` gives, is a shape like a list
    assert C.static_shape(np.array([16, 12])) == (16, 12)
    assert C.static_shape(jnp.array([16, 12, 3])) == (16, 12)
    with pytest.raises(ValueError, match="`shape` must be an image shape"):
        C.static_shape(np.array([[16, 12]]))
    with pytest.raises(TypeError, match=r"`shape\[1\]`"):
        C.static_shape(np.array([16.0, 12.5]))
    with pytest.raises(TypeError, match="`shape`"):
        jax.jit(lambda s: C.static_shape(s))(jnp.array([16, 12]))
    assert C.check_allocation(10, "n") == 10
    with pytest.raises(ValueError, match="`n` asks for 134217729 array elements"):
        C.check_allocation(C.MAX_ELEMENTS + 1, "n")


@pytest.mark.parametrize(
    ("value", "error", "message"),
    [
        (None, TypeError, "`a` must be an array of numbers, got None"),
        ("abc", TypeError, "`a` must be an array of numbers, got str"),
        (b"ab", TypeError, "`a` must be an array of numbers, got bytes"),
        ({"k": 1}, TypeError, "`a` must be an array of numbers, got dict"),
        ([1 + 2j], TypeError, "`a` must be real"),
        (np.array(["x"]), TypeError, "`a` must be an array of numbers"),
        ([[1, 2], [3]], ValueError, "`a` must be a rectangular array"),
        (2**100, ValueError, "`a` holds a number too large"),
    ],
)
def test_as_float_rejects(value, error, message):
    with pytest.raises(error, match=message):
        C.as_float(value, "a")


def test_as_float_and_common_float_dtypes():
    assert C.as_float(3, "a").dtype == jnp.float64
    assert C.as_float(jnp.ones(2, jnp.float32), "a").dtype == jnp.float32
    assert C.as_float([True, False], "a").dtype == jnp.float64
    a, b = C.common_float(jnp.ones(2, jnp.float32), 1, names=("a", "b"))
    assert a.dtype == b.dtype
    with pytest.raises(TypeError, match="`b` must be an array of numbers, got None"):
        C.common_float(1.0, None, names=("a", "b"))
    assert C.not_none(3, "a") == 3
    with pytest.raises(TypeError, match="`a` is required, got None"):
        C.not_none(None, "a")


def test_shape_checks():
    x = jnp.ones((5, 2, 3))
    C.check_shape(x, "x", (..., None, 3))
    assert C.check_last_dim(x, "x", (2, 3)) == 3
    with pytest.raises(ValueError, match=r"`x` must have shape \(\.\.\., 4\), got shape"):
        C.check_shape(x, "x", (..., 4))
    with pytest.raises(
        ValueError, match=r"`x` must be a 2-D array of shape \(any, 3\), got shape \(5, 2, 3\)"
    ):
        C.check_shape(x, "x", (None, 3))
    with pytest.raises(ValueError, match=r"`x` must be a 2-D array \(any sizes\), got shape"):
        C.check_shape(x, "x", (None, None))  # not "(n, n)": nothing says the sizes are equal
    with pytest.raises(
        ValueError, match=r"`x` must have shape \(\.\.\., any, 4\) \(at least 2 dimensions\)"
    ):
        C.check_shape(x, "x", (..., None, 4))
    with pytest.raises(ValueError, match=r"`x` must have shape \(4,\), got shape \(5, 2, 3\)"):
        C.check_shape(x, "x", (4,))  # a one-entry shape is written as a tuple
    with pytest.raises(ValueError, match=r"`x` must have shape \(\.\.\., 2\) \(points\)"):
        C.check_last_dim(x, "x", (2,), "points")
    with pytest.raises(ValueError, match="`s` must have shape"):
        C.check_last_dim(jnp.ones(()), "s", (2,))
    # under jit shapes are static, so the same ValueError is raised at trace time
    with pytest.raises(ValueError, match=r"`x` must have shape \(\.\.\., 4\)"):
        jax.jit(lambda v: C.check_shape(v, "x", (..., 4)))(x)
    # `what` names where an expected size comes from (so both arguments are named)
    pixels = "the pixel shape of `image`"
    with pytest.raises(
        ValueError,
        match=r"`d` must have shape \(0, 8\) \(the pixel shape of `image`\), got shape \(8, 8\)",
    ):
        C.check_shape(jnp.ones((8, 8)), "d", (0, 8), pixels)
    with pytest.raises(
        ValueError, match=r"`d` must have shape \(0, 8\) \(the pixel shape of `image`\)"
    ):
        jax.jit(lambda v: C.check_shape(v, "d", (0, 8), pixels))(jnp.ones((8, 8)))


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (None, "`i` must be an integer array of indices, got None"),
        ("abc", "`i` must be an integer array of indices, got 'abc'"),
        (["a", "b"], "`i` must be an integer array of indices, got list"),
        ([[1, 2], [3]], "`i` must be an integer array of indices, got list"),
        (np.array(["a"]), "`i` must be an integer array of indices, got ndarray"),
        (object(), "`i` must be an integer array of indices, got object"),
        (np.zeros(3), "`i` must be an integer array of indices, got dtype float"),
        (jnp.zeros(3, bool), "`i` must be an integer array of indices, got dtype bool"),
        (1.5, "`i` must be an integer array of indices, got dtype float"),
    ],
)
def test_as_int_rejects(value, message):
    with pytest.raises(TypeError, match=re.escape(message)):
        C.as_int(value, "i", "indices")


def test_as_int_keeps_integer_dtypes_eagerly_and_under_jit():
    for value in ([1, 2], np.array([1, 2], np.uint8), jnp.array([1, 2], jnp.int16), 3):
        out = C.as_int(value, "i")
        assert jnp.issubdtype(out.dtype, jnp.integer)
        np.testing.assert_array_equal(out, np.asarray(value))
    assert C.as_int(np.array([1], np.uint8), "i").dtype == jnp.uint8
    traced = jax.jit(lambda v: C.as_int(v, "i") * 2)(jnp.array([1, 2]))
    np.testing.assert_array_equal(traced, [2, 4])
    with pytest.raises(TypeError, match="`i` must be an integer array, got dtype float"):
        jax.jit(lambda v: C.as_int(v, "i"))(jnp.zeros(2))


def test_safe_helpers_have_finite_gradients_at_zero():
    zero = jnp.zeros(3)
    assert C.safe_norm(zero) == 0
    assert jnp.all(jnp.isfinite(jax.grad(C.safe_norm)(zero)))
    assert jnp.all(jnp.isfinite(jax.jacobian(C.safe_normalize)(zero)))
    np.testing.assert_allclose(C.safe_normalize(jnp.array([3.0, 4.0])), [0.6, 0.8])
    check_grads(jax.jit(C.safe_norm), (jnp.array([1.0, -2.0, 0.5]),), order=2, modes=["rev"])
    big = C.safe_divide(jnp.array(1.0), jnp.array(0.0))
    assert jnp.isfinite(big) and big > 0
    assert C.safe_divide(jnp.array(1.0), jnp.array(-0.0 - 1e-300)) < 0
    assert jnp.isfinite(jax.grad(lambda d: C.safe_divide(1.0, d))(0.0))


def test_is_traced():
    assert not C.is_traced({"a": jnp.ones(2)})
    seen = []
    jax.jit(lambda x: seen.append(C.is_traced({"a": x})) or x)(1.0)
    assert seen == [True]


def test_trusted_values_skip_traced_checks_and_keep_them_cached_apart():
    @jax.jit
    def core(x):
        return C.check_finite(x, "x") * 2

    nan = jnp.array(jnp.nan)
    with C.trusted_values():
        assert bool(jnp.isnan(core(nan)))  # the traced check is skipped inside
        with pytest.raises(ValueError, match="`x` must be finite"):
            C.check_finite(np.nan, "x")  # a concrete value is still checked
    # The trace made inside is not reused outside: the check is back.
    with pytest.raises(Exception, match="`x` must be finite"):
        core(nan).block_until_ready()
