"""Argument checks shared by every module.

**Static problems** (a wrong shape, a wrong type, `None` for an array, a size out of
range) raise `TypeError`/`ValueError` at once, eagerly and at trace time alike, with a
message that names the argument and says what was expected.

**Value problems** (NaN or inf where a number is needed, a value out of its range, a
degenerate window) are checked by `value_error_if` and the helpers built on it
(`check_finite`, `finite_float`, `check_range`, `check_rect`):

- called eagerly, or on values JAX knows at trace time: `ValueError(message)` at once;
- inside `jax.jit` on traced values: the check goes through `equinox.error_if` and fires
  when the compiled program runs. JAX wraps every exception raised while a compiled
  program runs in its own `jax.errors.JaxRuntimeError` (on some dispatch paths a
  `ValueError`): an `INTERNAL: CpuCallback error` with a long traceback, the same
  `message` inside it on a line of its own. Under
  `equinox.filter_jit` the error is an `equinox.EquinoxRuntimeError` with that message;
  under `checked_jit` (a drop-in `jax.jit`) it is the same
  `ValueError(message)` as eagerly. `check_message(err)` recovers the message from any
  of these exceptions.

So the message is the same on every path; only the exception class that carries it
depends on the `jit` used. (`EQX_ON_ERROR=nan` makes failing traced checks return NaN,
`EQX_ON_ERROR=off` disables them; the default is `raise`.)

**Size limits.** Integer sizes that allocate memory go through `static_int(...,
maximum=)`; `check_allocation` refuses a request above `MAX_ELEMENTS` elements (1 GiB
of float64) before anything is allocated.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import operator
from collections.abc import Callable, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._check_errors import check_message, host_check
from ._plain_args import flag

# Safe math lives in `_safe_math`; the checks' users import it from here too.
from ._safe_math import safe_divide as safe_divide
from ._safe_math import safe_norm as safe_norm
from ._safe_math import safe_normalize as safe_normalize


class _DropCheckFailureLogs(logging.Filter):
    """JAX logs every exception raised in a host callback before re-raising it; a failed
    check would print its traceback twice. Drop that log for equinox check failures
    only (the exception itself still propagates with its message)."""

    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return type(exc).__name__ != "_EquinoxRuntimeError"


logging.getLogger("jax._src.callback").addFilter(_DropCheckFailureLogs())

#: The most array elements a size argument may ask for (2**27: 1 GiB of float64).
MAX_ELEMENTS = 2**27


def is_traced(x) -> bool:
    """True when `x` (or any leaf of it) is a JAX tracer, i.e. its value is unknown."""
    return any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(x))


def function_holds_tracer(fn) -> bool:
    """Whether the function `fn` holds a traced value: in its closure, its defaults, a
    `functools.partial`'s arguments, or its array leaves (an `eqx.Module`). A driver such
    as `gfxlab.fit.fit` uses it to tell a call under an outer transformation apart from a
    mistake inside `fn`."""
    held = [getattr(fn, "__defaults__", None), getattr(fn, "__kwdefaults__", None)]
    held += [cell.cell_contents for cell in getattr(fn, "__closure__", None) or ()
             if cell.cell_contents is not fn]  # fmt: skip
    if isinstance(fn, functools.partial):
        held += [fn.func, fn.args, fn.keywords]
    try:
        held.append(eqx.filter(fn, eqx.is_array))
    except Exception:  # not a pytree we can read: nothing more to look at
        pass
    return is_traced(held)


def not_none(x, name: str):
    """`x` unchanged, after checking it is not `None` (`TypeError` naming `name`)."""
    if x is None:
        raise TypeError(f"`{name}` is required, got None")
    return x


def to_jax(x, *, floating: bool = False) -> jax.Array:
    """`jnp.asarray(x)`, without compiling anything for host data.

    JAX compiles a small copy program for `jnp.asarray` of a NumPy array (a conversion for
    a list) once per shape and dtype: 10-30 ms for every new shape a user passes to an
    eager function. NumPy arrays, lists and tuples of numbers are therefore converted by
    NumPy to JAX's canonical dtype (integers and booleans to the default float dtype with
    `floating=True`) and moved with `jax.device_put`. Anything else (JAX arrays, tracers,
    Python scalars, which stay weakly typed) goes to `jnp.asarray`, as do inputs NumPy
    cannot hold as numbers (so that JAX's own errors are kept).
    """
    if isinstance(x, np.ndarray | list | tuple) and not is_traced(x):
        arr = np.asarray(x)
        if arr.dtype.kind in "biuf":
            dtype = jnp.result_type(float) if floating and arr.dtype.kind != "f" else arr.dtype
            return jax.device_put(arr.astype(jax.dtypes.canonicalize_dtype(dtype), copy=False))
    arr = jnp.asarray(x)
    if floating and not _is_floating(arr.dtype) and arr.dtype.kind in "biu":
        arr = arr.astype(jnp.result_type(float))
    return arr


def as_float(x, name: str = "x") -> jax.Array:
    """`x` as a floating JAX array, keeping a floating input dtype.

    Integer and boolean inputs become the default float dtype (float32, or float64
    under `jax_enable_x64`). `None`, strings and other non-numbers raise `TypeError`
    naming the argument; ragged nested lists raise `ValueError`.
    """
    if isinstance(x, jax.Array) and _is_floating(x.dtype):
        return x  # the common case, without a dispatch
    if x is None:
        raise TypeError(f"`{name}` must be an array of numbers, got None")
    if isinstance(x, str | bytes):
        raise TypeError(f"`{name}` must be an array of numbers, got {type(x).__name__} {x!r:.40}")
    try:
        arr = to_jax(x, floating=True)
    except TypeError as err:
        raise TypeError(f"`{name}` must be an array of numbers, got {type(x).__name__}") from err
    except OverflowError as err:
        raise ValueError(f"`{name}` holds a number too large for an array: {x!r:.60}") from err
    except ValueError as err:
        raise ValueError(
            f"`{name}` must be a rectangular array of numbers (not a ragged list), got "
            f"{type(x).__name__}"
        ) from err
    if jnp.issubdtype(arr.dtype, jnp.complexfloating):
        raise TypeError(f"`{name}` must be real, got dtype {arr.dtype}")
    if not jnp.issubdtype(arr.dtype, jnp.floating):  # (`to_jax` made numbers floats)
        raise TypeError(f"`{name}` must be an array of numbers, got dtype {arr.dtype}")
    return arr


def as_numeric(x, name: str = "x") -> jax.Array:
    """`x` as a JAX array of integers or finite floats, keeping its dtype (indices,
    positions). `None`, strings and non-numbers raise `TypeError` naming the argument."""
    if isinstance(x, jax.Array) and jnp.issubdtype(x.dtype, jnp.integer):
        return x
    if x is None or isinstance(x, str | bytes):
        raise TypeError(f"`{name}` must be an array of numbers, got {type(x).__name__}")
    try:
        arr = to_jax(x)
    except (TypeError, ValueError, OverflowError) as err:
        raise TypeError(f"`{name}` must be an array of numbers, got {type(x).__name__}") from err
    if jnp.issubdtype(arr.dtype, jnp.integer):
        return arr
    return check_finite(as_float(arr, name), name)


def common_float(*arrays, names: Sequence[str]) -> list[jax.Array]:
    """Several arrays as floats promoted to one common dtype."""
    arrays = [as_float(a, n) for a, n in zip(arrays, names, strict=True)]
    dtype = jnp.result_type(*arrays)
    return [a if a.dtype == dtype else a.astype(dtype) for a in arrays]


def follow_float(*values, names: Sequence[str], default=None) -> list[jax.Array]:
    """Several values as floats of one dtype, led by those given as arrays.

    The dtype is the common one of the values that are (non-weakly typed) NumPy or JAX
    arrays; Python numbers, lists and tuples (e.g. a default `1.0` or `(0.0, 1.0, 0.0)`)
    follow it instead of promoting it, so float32 arrays stay float32 under
    `jax_enable_x64`. With no array among `values` the dtype is `default` (e.g. that of a
    related field), else JAX's default float dtype.
    """
    arrays = [as_float(v, n) for v, n in zip(values, names, strict=True)]
    given = [
        a.dtype
        for v, a in zip(values, arrays, strict=True)
        if isinstance(v, np.ndarray | np.generic | jax.Array) and not getattr(v, "weak_type", False)
    ]
    if given:
        dtype = jnp.result_type(*given)
    else:
        dtype = jnp.result_type(float) if default is None else jnp.dtype(default)
    return [a if a.dtype == dtype else a.astype(dtype) for a in arrays]


def check_last_dim(x: jax.Array, name: str, sizes: Sequence[int], what: str = "") -> int:
    """Check that `x.shape[-1]` is one of `sizes`; return it."""
    if x.ndim == 0 or x.shape[-1] not in sizes:
        allowed = " or ".join(str(s) for s in sizes)
        hint = f" ({what})" if what else ""
        raise ValueError(
            f"`{name}` must have shape (..., {allowed}){hint}, got shape {tuple(x.shape)}"
        )
    return x.shape[-1]


def as_int(x, name: str = "x", what: str = "") -> jax.Array:
    """`x` as a JAX integer array (indices, labels), keeping its integer dtype.

    `None`, strings, non-numbers and floating or boolean arrays raise `TypeError` naming
    the argument (`what` says what it holds, e.g. "face indices").
    """
    if isinstance(x, jax.Array) and jnp.issubdtype(x.dtype, jnp.integer):
        return x  # the common case, without a dispatch
    hint = f" of {what}" if what else ""
    if x is None or isinstance(x, str | bytes):
        raise TypeError(f"`{name}` must be an integer array{hint}, got {x!r:.40}")
    try:
        if isinstance(x, list | tuple) and np.asarray(x).dtype.kind not in "biuf":
            raise TypeError("not numbers")  # (strings: before JAX warns about their dtype)
        arr = to_jax(x)
    except (TypeError, ValueError, OverflowError) as err:
        raise TypeError(f"`{name}` must be an integer array{hint}, got {type(x).__name__}") from err
    if not jnp.issubdtype(arr.dtype, jnp.integer):
        raise TypeError(f"`{name}` must be an integer array{hint}, got dtype {arr.dtype}")
    return arr


def check_shape(x: jax.Array, name: str, shape: tuple, what: str = "") -> None:
    """Check that `x.shape` matches `shape`, where `None` entries match any size and a
    leading `...` matches any batch dimensions. `what` says where an expected size
    comes from (e.g. "the pixel shape of `image`"), so that a mismatch names both
    arguments."""
    shape = tuple(shape)
    batch = len(shape) > 0 and shape[0] is Ellipsis
    core = shape[1:] if batch else shape
    actual = tuple(x.shape)
    ok = len(actual) >= len(core) if batch else len(actual) == len(core)
    if ok:
        tail = actual[len(actual) - len(core) :] if core else ()
        ok = all(c is None or c == a for c, a in zip(core, tail, strict=True))
    if not ok:
        hint = f" ({what})" if what else ""
        raise ValueError(f"`{name}` must {_shape_words(shape)}{hint}, got shape {actual}")


def _shape_words(shape: tuple) -> str:
    """An expected shape in words and numbers: "have shape (4,)", "have shape (..., 3)",
    "be a 3-D array of shape (any, 2, 2)", "be a 2-D array (any sizes)"."""
    pretty = ", ".join("..." if s is Ellipsis else "any" if s is None else str(s) for s in shape)
    pretty += "," if len(shape) == 1 else ""  # written as Python writes the tuple: (4,)
    if None not in shape:
        return f"have shape ({pretty})"
    if Ellipsis in shape:
        return f"have shape ({pretty}) (at least {len(shape) - 1} dimensions)"
    if all(s is None for s in shape):
        return f"be a {len(shape)}-D array (any sizes)"
    return f"be a {len(shape)}-D array of shape ({pretty})"


def static_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """A static (Python) integer argument, such as a radius, a degree or an image size.

    `maximum` bounds sizes that allocate memory, so a huge value is refused before any
    allocation rather than hanging or exhausting memory. `None` and non-integers raise
    `TypeError`, values out of range `ValueError`; both name the argument.
    """
    if isinstance(value, jax.core.Tracer):
        raise TypeError(
            f"`{name}` sets an array size, so it must be a static Python int, not a traced "
            "value; mark it static (e.g. `jax.jit(f, static_argnames=...)`)"
        )
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        if (
            isinstance(value, float | np.floating)
            and math.isfinite(value)
            and float(value).is_integer()
        ):
            value = int(value)
        elif (
            isinstance(value, np.ndarray | jax.Array)
            and value.shape == ()
            and jnp.issubdtype(value.dtype, jnp.integer)
        ):
            value = int(value)
        else:
            raise TypeError(f"`{name}` must be an int, got {value!r:.60}")
    value = operator.index(value)
    if minimum is not None and value < minimum:
        raise ValueError(f"`{name}` must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise ValueError(f"`{name}` must be <= {maximum} (a documented size limit), got {value}")
    return value


#: A flag's check (`True`/`False` or a NumPy bool; `bool("no")` would be True), the one
#: `gfxlab._plain_args` owns for the JAX-free modules too.
static_bool = flag


def static_shape(shape, name: str = "shape") -> tuple[int, int]:
    """An image shape `(H, W)` (extra trailing entries such as channels are ignored).

    Each side is at most `MAX_ELEMENTS`, and so is `H * W`. A 1-D NumPy or concrete
    JAX array (e.g. `np.array(image.shape)`) counts as a sequence of its entries.
    """
    if is_traced(shape):
        raise TypeError(
            f"`{name}` sets an array size, so it must be a static shape such as (H, W), "
            "not a traced array (pass it to `jax.jit` as a static argument, as a tuple: "
            "a NumPy array is not hashable)"
        )
    if isinstance(shape, np.ndarray | jax.Array) and shape.ndim == 1:
        shape = tuple(np.asarray(shape).tolist())
    if not isinstance(shape, Sequence) or isinstance(shape, str) or len(shape) < 2:
        raise ValueError(f"`{name}` must be an image shape (H, W), got {shape!r:.60}")
    height = static_int(shape[0], f"{name}[0]", minimum=1, maximum=MAX_ELEMENTS)
    width = static_int(shape[1], f"{name}[1]", minimum=1, maximum=MAX_ELEMENTS)
    check_allocation(height * width, name)
    return height, width


def check_allocation(elements: int, name: str, *, limit: int = MAX_ELEMENTS) -> int:
    """Refuse a request for more than `limit` array elements (default `MAX_ELEMENTS`).

    Call it with the number of elements a size argument `name` makes a function
    allocate, before allocating. Returns `elements`.
    """
    if elements > limit:
        raise ValueError(
            f"`{name}` asks for {elements} array elements, more than gfxlab's limit of "
            f"{limit} per array (1 GiB of float64): ask for less, or work in pieces"
        )
    return elements


def value_error_if(x, bad, message: str):
    """Raise `ValueError(message)` if `bad` holds anywhere.

    A `bad` whose value is known (eagerly, or a constant at trace time) raises at once.
    A traced `bad` goes through `equinox.error_if`, which raises when the compiled
    program runs (see the module docstring for the exception that carries `message`
    under each kind of `jit`). Returns `x`, which must be used, so that the check is not
    dead code under `jit`.
    """
    if not is_traced(bad):
        if bool(np.any(np.asarray(bad))):
            raise ValueError(message)
        return x
    if _TRUSTED is not None and _TRUSTED.value:
        return x
    return eqx.error_if(x, bad, message)


def attach_check(x, bad, message: str):
    """Inside a jitted function: `x` after `value_error_if(..., bad, message)`, with the
    check attached to a scalar `1` that multiplies `x` (exact), so that it costs one
    fused reduction of `bad`, not a copy of `x` through a conditional."""
    one = value_error_if(jnp.ones((), x.dtype), jnp.any(bad), message)
    return x * one


# A JAX user context, so that jitted functions traced inside `trusted_values` are cached
# apart from their checked traces (a later call from a user's `jit` still checks). A JAX
# without user contexts keeps every check.
_TRUSTED = jax.make_user_context(False) if hasattr(jax, "make_user_context") else None


def trusted_values():
    """A context in which traced value checks are skipped, for the body of a compiled core.

    Use it inside a core whose public wrapper has checked its inputs: the gfxlab functions
    it calls then see those checked inputs or values the core computed itself, and each of
    their checks would only add a host callback to the program (the renderer's program had
    53, which made it compile a third slower). Checks of concrete values still raise.
    """
    return _TRUSTED(True) if _TRUSTED is not None else contextlib.nullcontext()


def host_value(x) -> np.ndarray | None:
    """`x` as a NumPy array when its value is known and already in host memory (a NumPy
    array, a Python number, a concrete JAX array on the CPU), else `None`.

    Eager checks test such values with NumPy: one JAX dispatch per check costs tens of
    microseconds, NumPy a few, and a traced or accelerator-resident value keeps the JAX
    path (no device-to-host copy).
    """
    if isinstance(x, np.ndarray | np.generic | int | float | bool):
        return np.asarray(x)
    if isinstance(x, jax.Array) and not isinstance(x, jax.core.Tracer) and _host_backend():
        try:
            return np.asarray(x)
        except (RuntimeError, ValueError):  # deleted or donated buffers
            return None
    return None


@functools.cache
def _host_backend() -> bool:
    """True when JAX computes on the CPU, so every concrete array is in host memory."""
    return jax.default_backend() == "cpu"


@functools.cache
def _is_floating(dtype) -> bool:
    return bool(jnp.issubdtype(dtype, jnp.floating))


def check_finite(x, name: str):
    """`x` unchanged, after checking that it holds no NaN or infinity (eagerly and under jit)."""
    host = host_value(x)
    if host is not None:
        if _is_floating(host.dtype) and not np.isfinite(host).all():
            raise ValueError(f"`{name}` must be finite (no NaN or inf)")
        return x
    with jax.ensure_compile_time_eval():  # a constant is checked at trace time
        bad = ~jnp.isfinite(x)
    return value_error_if(x, bad, f"`{name}` must be finite (no NaN or inf)")


def common_finite(*arrays, names: Sequence[str]) -> list[jax.Array]:
    """`common_float` that also rejects NaN and infinity, naming the argument."""
    return [
        check_finite(a, n) for a, n in zip(common_float(*arrays, names=names), names, strict=True)
    ]


def finite_float(x, name: str = "x") -> jax.Array:
    """`as_float(x, name)` that also rejects NaN and infinite values."""
    return check_finite(as_float(x, name), name)


def _bound_text(minimum, maximum, lower_open, upper_open, finite) -> str:
    """The range in words, accurate for every value it refuses: a finite interval
    refuses NaN and inf by itself; a half-line says "finite and" when infinities are
    refused too, else "and not NaN" (NaN fails every comparison)."""
    if minimum is not None and maximum is not None and np.isfinite([minimum, maximum]).all():
        left, right = "(" if lower_open else "[", ")" if upper_open else "]"
        return f"in {left}{minimum:g}, {maximum:g}{right}"
    parts = []
    if minimum is not None:
        parts.append(f"{'>' if lower_open else '>='} {minimum:g}")
    if maximum is not None:
        parts.append(f"{'<' if upper_open else '<='} {maximum:g}")
    text = " and ".join(parts)
    return f"finite and {text}" if finite else f"{text} and not NaN"


def check_range(
    x,
    name: str,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    lower_open: bool = False,
    upper_open: bool = False,
    finite: bool = False,
    what: str = "",
):
    """`x` unchanged, after checking `minimum <= x <= maximum` everywhere (eagerly and
    under jit). `lower_open`/`upper_open` make a bound strict; NaN always fails, and
    `finite=True` refuses infinities too (a half-line such as `minimum=0` alone
    otherwise lets `inf` through).

    The message names the argument and the range, and is true of every refused value:
    "`q` must be in [1, 100]", "`sigma` must be finite and > 0" (`finite=True`),
    "`tol` must be >= 0 and not NaN".
    """
    if minimum is None and maximum is None:
        raise TypeError("check_range needs `minimum` or `maximum`")
    host = host_value(x)
    # NumPy for a value in host memory, else JAX (a constant is checked at trace time).
    xp, value = (np, host) if host is not None else (jnp, x)
    with jax.ensure_compile_time_eval():
        ok = xp.isfinite(value) if finite else ~xp.isnan(value)
        if minimum is not None:
            ok = ok & ((value > minimum) if lower_open else (value >= minimum))
        if maximum is not None:
            ok = ok & ((value < maximum) if upper_open else (value <= maximum))
    hint = f" ({what})" if what else ""
    text = _bound_text(minimum, maximum, lower_open, upper_open, finite)
    return value_error_if(x, ~ok, f"`{name}` must be {text}{hint}")


def positive(x, name: str, what: str = ""):
    """`x` unchanged after checking it is finite and > 0 everywhere (eagerly and under
    jit): one check, whose message "`name` must be finite and > 0" holds for NaN, inf
    and values <= 0 alike."""
    return check_range(x, name, minimum=0, lower_open=True, finite=True, what=what)


def check_rect(rect, name: str) -> jax.Array:
    """A finite rectangle `(xmin, ymin, xmax, ymax)` with positive width and height."""
    rect = finite_float(rect, name)
    check_shape(rect, name, (4,))
    host = host_value(rect)
    values = host if host is not None else rect
    with jax.ensure_compile_time_eval():
        bad = (values[2] <= values[0]) | (values[3] <= values[1])
    return value_error_if(
        rect,
        bad,
        f"`{name}` must be (xmin, ymin, xmax, ymax) with xmax > xmin and ymax > ymin "
        "(a rectangle with positive width and height)",
    )


def checked_jit(fn: Callable | None = None, **jit_kwargs) -> Callable:
    """`jax.jit` whose failed value checks raise `ValueError(message)`, as they do eagerly.

    A drop-in replacement for `jax.jit` (same keyword arguments; usable as a decorator
    with or without them). A failed `equinox.error_if` (gfxlab's checks, or one of your
    own in the jitted function) becomes `ValueError(message)`, a failed host check its
    own `ValueError` subclass (`TileCapacityError`); other errors pass through unchanged.
    """
    if fn is None:
        return functools.partial(checked_jit, **jit_kwargs)
    compiled = jax.jit(fn, **jit_kwargs)
    call = _raising_check_messages(fn, compiled)
    call.lower = compiled.lower
    return call


def checked_filter_jit(fn: Callable) -> Callable:
    """`equinox.filter_jit` whose failed value checks raise `ValueError(message)`, as
    they do eagerly (for functions of pytrees holding callables or modules)."""
    return _raising_check_messages(fn, eqx.filter_jit(fn))


def _raising_check_messages(fn: Callable, compiled: Callable) -> Callable:
    @functools.wraps(fn)
    def call(*args, **kwargs):
        try:
            return compiled(*args, **kwargs)
        except (jax.errors.JaxRuntimeError, RuntimeError, ValueError) as err:
            message = check_message(err)
            if message is None or message == str(err):
                raise
            host = host_check(str(err)) if isinstance(err, jax.errors.JaxRuntimeError) else None
            raise (host[0] if host else ValueError)(message) from None

    return call


def check_key(key, name: str = "key", *, needed: bool = True):
    """A single `jax.random` key: a typed key (`jax.random.key`) or raw `uint32[2]` key
    data (`jax.random.PRNGKey`); may be traced. `None` passes only where nothing random
    is drawn (`needed=False`); anything else is a `TypeError` naming `name`."""
    if key is None and not needed:
        return None
    dtype = getattr(key, "dtype", None)
    shape = getattr(key, "shape", None)
    typed = dtype is not None and jnp.issubdtype(dtype, jax.dtypes.prng_key)
    raw = dtype == np.uint32 and shape == (2,)
    if not isinstance(key, jax.Array | np.ndarray) or not (typed and shape == () or raw):
        raise TypeError(
            f"`{name}` must be a jax.random key (one key, e.g. `jax.random.key(0)`), got "
            f"{type(key).__name__} {getattr(key, 'dtype', '')}{list(shape or [])}"
        )
    return key


def checked_unit(x: jax.Array, message: str, *, tiny=0.0, axis: int = -1) -> jax.Array:
    """`safe_normalize(x)`, refusing (`value_error_if(..., message)`) a length `<= tiny`.

    For directions that must exist (a rotation axis, a mirror normal, a viewing
    direction): the zero vector is always refused; `tiny` also refuses near-zero ones.
    """
    x = value_error_if(x, safe_norm(x, axis=axis, keepdims=True) <= tiny, message)
    return safe_normalize(x, axis=axis)
