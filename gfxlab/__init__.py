"""gfxlab: a differentiable computer-graphics lab in JAX.

Submodules are imported on first use (`gfxlab.transforms`, `gfxlab.viewing`, ...), so
`import gfxlab` stays light: it never imports colour-science, matplotlib or Pillow.

Two helpers for calling gfxlab inside your own `jax.jit` (also imported on first use):
`gfxlab.checked_jit`, a drop-in `jax.jit` whose failed value checks raise the same
`ValueError` as an eager call, and `gfxlab.check_message(err)`, the message of a failed
check carried by any exception JAX or Equinox raises for it.
"""

from __future__ import annotations

import importlib

from ._resources import data_file

__version__ = "0.1.0"

_SUBMODULES = (
    "transforms",
    "viewing",
    "raster",
    "clipping",
    "render",
    "mesh",
    "curves",
    "brdf",
    "color",
    "image",
    "jpeg",
    "animation",
    "fit",
    "exam",
    "grading",
)

# Public helpers of the shared check layer, imported on first use like the submodules.
_HELPERS = {"checked_jit": "_checks", "check_message": "_check_errors"}

__all__ = ["__version__", "data_file", *_HELPERS, *_SUBMODULES]


def __getattr__(name: str):
    if name in _HELPERS:
        value = getattr(importlib.import_module(f"{__name__}.{_HELPERS[name]}"), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module 'gfxlab' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
