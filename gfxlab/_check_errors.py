"""The message of a failed check, found in whichever exception carries it.

Eagerly a check raises `ValueError(message)`. Inside a compiled program, JAX wraps
what a check raises in its `JaxRuntimeError` (an `equinox.error_if`, or a
`HostCheckError` raised in a host callback), and `equinox.filter_jit` in an
`EquinoxRuntimeError`: `check_message` digs the message out of each (see `_checks`).
"""

from __future__ import annotations

import re

import jax

__all__ = ["HostCheckError", "check_message", "host_check"]

# The markers around a check's message in the runtime errors of `equinox.error_if`.
_EQX_MARKERS = ("_EquinoxRuntimeError: ", "equinox.EquinoxRuntimeError: ")
_EQX_FOOTER = re.compile(r"\n\s*\n\s*(-{5,}|\Z)")


class HostCheckError(ValueError):
    """A check that a compiled program makes on the host (in a `jax.debug.callback`):
    JAX wraps it in a `JaxRuntimeError` whose text ends `Name: message`, which
    `check_message` finds and `checked_jit` raises again as this class."""

    _registered: dict[str, type] = {}

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        HostCheckError._registered[cls.__name__] = cls


def host_check(text: str) -> tuple[type, str] | None:
    """The host check error class and message at the end of a `JaxRuntimeError`'s text."""
    for name, cls in HostCheckError._registered.items():
        start = text.rfind(f"\n{name}: ")
        if start >= 0:
            return cls, text[start + len(name) + 3 :].strip()
    return None


def check_message(err: BaseException) -> str | None:
    """The message of a failed check carried by `err`, or None if `err` carries none.

    Works for the `ValueError` raised eagerly, JAX's `JaxRuntimeError` under `jax.jit`
    (from `equinox.error_if`, or a `HostCheckError` such as a render's
    `TileCapacityError` raised in a host callback) and `equinox.EquinoxRuntimeError`
    under `equinox.filter_jit`. Any `equinox.error_if`
    counts (gfxlab's or your own), and so does any plain `ValueError`/`TypeError`, whose
    text is returned: eager checks fail that way, so this cannot tell gfxlab's eager
    errors from others; `None` means `err` is some other runtime error.
    """
    text = str(err)
    for marker in _EQX_MARKERS:
        start = text.rfind(marker)
        if start >= 0:
            body = text[start + len(marker) :]
            end = _EQX_FOOTER.search(body)
            return (body[: end.start()] if end else body).strip()
    if type(err).__name__ == "EquinoxTracetimeError":
        return text.strip()
    if isinstance(err, jax.errors.JaxRuntimeError) and (host := host_check(text)):
        return host[1]
    if isinstance(err, ValueError | TypeError) and not isinstance(err, jax.errors.JaxRuntimeError):
        return text
    return None
