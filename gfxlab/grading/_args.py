"""Checks of what callers pass to the public grading functions (no processes here).

A caller's mistake must fail at once and say so, never become a student's failure or a
silent success: a wrong type raises `TypeError`, a bad value `ValueError`, each naming
the argument and what it takes. `read_config` reads an autograder's `config.json`.
"""

from __future__ import annotations

import json
import pathlib

from .._plain_args import flag as flag  # re-exported: the grading modules' one import
from .._plain_args import shown as _shown
from ._policy import Limits


def module_names(value, name: str) -> tuple[str, ...]:
    """`value` if it is a list or tuple of dotted module names (`"scipy.fft"`): a string
    alone would stand for its characters, so it is refused like any non-list."""
    if not isinstance(value, list | tuple):
        raise TypeError(
            f"`{name}` must be a list or tuple of module names (e.g. ['scipy']), "
            f"got {_shown(value)}"
        )
    for module in value:
        if not isinstance(module, str):
            raise TypeError(f"`{name}` must hold module names (str), got {_shown(module)}")
        if not all(part.isidentifier() for part in module.split(".")):
            raise ValueError(
                f"`{name}`: {_shown(module)} is not a dotted module name (e.g. 'scipy.fft')"
            )
    return tuple(value)


def limits_arg(value, name: str, *, overrides: bool = False):
    """`value` if it is a `Limits` (or, with `overrides`, None or a dict of `Limits`
    fields), else `TypeError`."""
    if isinstance(value, Limits) or (overrides and (value is None or isinstance(value, dict))):
        return value
    expected = "a Limits, a dict of Limits fields or None" if overrides else "a Limits"
    raise TypeError(f"`{name}` must be {expected}, got {_shown(value)}")


def run_test_args(test, spec, session, rename) -> dict:
    """The arguments of `Autograder.run_test` checked (a caller's mistake, not the
    student's failure): **Returns:** `rename` as a dict."""
    from .authoring import TestSpec

    if not callable(test):
        raise TypeError(f"`test` must be a callable (a test function), got {_shown(test)}")
    if not isinstance(spec, TestSpec):
        raise TypeError(f"`spec` must be an authoring.TestSpec, got {_shown(spec)}")
    if not callable(getattr(session, "call", None)):
        raise TypeError(
            f"`session` must have a callable `call` (a StudentSession), got {_shown(session)}"
        )
    if rename is not None and not isinstance(rename, dict):
        raise TypeError(f"`rename` must be a dict or None, got {_shown(rename)}")
    return rename or {}


_QUESTION_KEYS = ("name", "points", "tests")
_TEST_KEYS = ("name", "params", "hidden", "weight")


def read_config(directory: pathlib.Path) -> dict:
    """An autograder directory's `config.json`, checked for what the grader reads.

    **Raises:** `FileNotFoundError` when there is none ("is this an autograder
    directory?"); `ValueError` naming the file and the missing or wrong key.
    """
    path = directory / "config.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: is this an autograder directory?")
    try:
        config = json.loads(path.read_text())
    except ValueError as exc:
        raise ValueError(f"{path} is not valid JSON: {exc}") from None

    def require(mapping, keys, where):
        if not isinstance(mapping, dict):
            raise ValueError(f"{path}: {where} must be a JSON object")
        missing = [k for k in keys if k not in mapping]
        if missing:
            raise ValueError(f"{path}: {where} lacks the key `{missing[0]}`")

    require(config, ("assignment", "questions"), "the configuration")
    if not isinstance(config["questions"], list):
        raise ValueError(f"{path}: `questions` must be a list")
    for i, question in enumerate(config["questions"]):
        require(question, _QUESTION_KEYS, f"question {i}")
        if not isinstance(question["tests"], list):
            raise ValueError(f"{path}: `tests` of question {i} must be a list")
        for j, test in enumerate(question["tests"]):
            require(test, _TEST_KEYS, f"test {j} of question {i}")
    if not isinstance(config.get("x64", True), bool):
        raise ValueError(f"{path}: `x64` must be true or false, got {_shown(config['x64'])}")
    for key in ("preload", "forbid"):
        try:
            module_names(config.get(key, []), key)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {exc}") from None
    return config
