"""Package layout only; everything else is in pyproject.toml.

The top-level `data/` and `labs/` folders are part of the project's agreed layout and
ship inside the wheel as `gfxlab._data` and `gfxlab._labs`, so an installed gfxlab is
whole (CIE tables, meshes, the teapot, the sample scene, the notebooks).
"""

from setuptools import find_packages, setup

setup(
    packages=[*find_packages(include=["gfxlab", "gfxlab.*"]), "gfxlab._data", "gfxlab._labs"],
    package_dir={"gfxlab._data": "data", "gfxlab._labs": "labs"},
)
