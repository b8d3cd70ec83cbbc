"""gfxlab: a differentiable computer-graphics lab in JAX.

Submodules are imported on first use (`gfxlab.transforms`, `gfxlab.viewing`, ...), so
`import gfxlab` stays light: it never imports colour-science, matplotlib or Pillow.
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

__all__ = ["__version__", "data_file", *_SUBMODULES]


def __getattr__(name: str):
    if name in _SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module 'gfxlab' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
