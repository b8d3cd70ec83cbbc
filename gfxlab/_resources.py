"""Files shipped with gfxlab: the top-level `data/` and `labs/` folders of the project.

Both ship inside the wheel as the packages `gfxlab._data` and `gfxlab._labs` (a
setuptools `package-dir` mapping), so they are found the same way in a checkout, an
editable install and a wheel installed anywhere.
"""

from __future__ import annotations

import contextlib
import importlib.resources
import pathlib
import shutil

__all__ = ["data_file", "data_folder", "labs_dir", "copy_labs"]


def _folder(package: str) -> pathlib.Path:
    root = importlib.resources.files(package)
    # Installed wheels and editable installs both give a real directory.
    return pathlib.Path(str(root))


def data_file(*parts: str) -> pathlib.Path:
    """The path of a shipped data file, e.g. `data_file("teapot", "teapot.txt")`.

    **Raises:** `FileNotFoundError` naming the file when it is not shipped.
    """
    path = _folder("gfxlab._data").joinpath(*parts)
    if not path.is_file():
        raise FileNotFoundError(f"gfxlab data file {'/'.join(parts)!r} is not installed")
    return path


def data_folder(*parts: str) -> pathlib.Path:
    """The path of a shipped data folder, e.g. `data_folder("color")`."""
    return _folder("gfxlab._data").joinpath(*parts)


def labs_dir() -> pathlib.Path:
    """The folder holding the lab notebooks (`NN_topic.ipynb`).

    In a checkout it also holds the instructors' `assignments/` sources; a wheel never
    ships those (they contain solutions and hidden tests).
    """
    return _folder("gfxlab._labs")


def copy_labs(destination) -> list[pathlib.Path]:
    """Copy the lab notebooks into `destination` (created if missing).

    Existing files of the same name are left alone, so a student's edited copy is never
    overwritten. Returns the paths written.
    """
    destination = pathlib.Path(destination)
    source = labs_dir()
    written = []
    for notebook in sorted(source.glob("[0-9]*.ipynb")):
        target = destination / notebook.name
        if target.exists():
            continue
        destination.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(shutil.SameFileError):
            shutil.copyfile(notebook, target)
        written.append(target)
    return written
