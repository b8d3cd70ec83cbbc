"""The wheel is whole: built from the checkout, installed outside it, every data file found.

The wheel is built from a clean copy of the tracked files (`git ls-files`), so a
stale `build/` folder of the checkout (modules that were since split or removed)
cannot leak into it; its Python modules must be exactly the tracked ones.

The wheel goes into a fresh virtual environment in a temporary directory. Its
dependencies are not downloaded again: the environment sees the test run's own
site-packages through a `.pth` path entry (appended after the wheel's own folder, and
without running that folder's `.pth` hooks, so the checkout's editable install stays
out of sight). The smoke test then runs from a directory outside the checkout and
checks that gfxlab was imported from the wheel.
"""

import email.parser
import os
import pathlib
import re
import shutil
import subprocess
import sys
import sysconfig
import venv
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]

SMOKE = r"""
import sys, tempfile
import gfxlab
assert "site-packages" in gfxlab.__file__, gfxlab.__file__
from gfxlab import color, curves, image, labs, mesh
assert color.cmfs().shape[-1] == 3
assert color.illuminant_d65()[0].shape[0] > 50
teapot = curves.teapot()
pawn = mesh.read_obj(mesh.shipped_model_path("pawn.obj"))
scene = image.read_image(gfxlab.data_file("images", "scene.png"))
assert scene.ndim == 3, scene.shape
shipped = labs.list_labs()  # the labs of the wheel: GFXLAB_LABS is not set
assert len(shipped) >= 10, shipped
assert all("site-packages" in str(p) for p in shipped), shipped
assert not (shipped[0].parent / "assignments").exists(), "assignment sources shipped"
print("ok")
"""

# Notebook tooling belongs to the `lab` extra: a plain `pip install gfxlab` must not pull it.
NOTEBOOK_TOOLS = re.compile(r"^(jupyter|ipywidgets|nbclient|nbconvert|notebook)", re.IGNORECASE)


# The installed copy must be found through the venv alone, not a PYTHONPATH to the checkout
# (and its labs are the shipped ones, not a `$GFXLAB_LABS` folder).
CLEAN_ENV = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "GFXLAB_LABS")}


def _tracked_files() -> list[str]:
    listing = subprocess.run(
        ["git", "ls-files", "-z"], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout
    return [name for name in listing.split("\0") if name and (ROOT / name).is_file()]


def _clean_copy(destination: pathlib.Path) -> pathlib.Path:
    """The tracked files of the checkout (as in the working tree) and nothing else."""
    for name in _tracked_files():
        target = destination / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target)
    return destination


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> pathlib.Path:
    out = tmp_path_factory.mktemp("wheel")
    source = _clean_copy(tmp_path_factory.mktemp("source"))
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(out),
            str(source),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    (path,) = out.glob("gfxlab-*.whl")
    return path


def test_wheel_ships_data_and_labs_but_no_assignment_sources(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    assert "gfxlab/_data/teapot/teapot.txt" in names
    assert "gfxlab/_data/color/cie_observer.csv" in names
    assert "gfxlab/_data/meshes/pawn.obj" in names
    assert "gfxlab/_data/images/scene.png" in names
    assert any(n.startswith("gfxlab/_labs/00_") for n in names)
    assert not any("assignments" in n for n in names), "assignment sources must never ship"
    assert not any(n.startswith(("tests/", "data/", "labs/")) for n in names)


def test_wheel_modules_are_exactly_the_tracked_sources(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    shipped = {
        n
        for n in names
        if n.startswith("gfxlab/")
        and n.endswith(".py")
        and not n.startswith(("gfxlab/_data/", "gfxlab/_labs/"))
    }
    tracked = {n for n in _tracked_files() if n.startswith("gfxlab/") and n.endswith(".py")}
    assert shipped == tracked, (sorted(shipped - tracked), sorted(tracked - shipped))
    # The data and lab subpackages hold only their package markers as code.
    resource_code = {n for n in names if n.startswith(("gfxlab/_data/", "gfxlab/_labs/"))}
    resource_code = {n for n in resource_code if n.endswith(".py")}
    assert resource_code == {"gfxlab/_data/__init__.py", "gfxlab/_labs/__init__.py"}


def test_wheel_runtime_requirements_leave_out_the_notebook_server(wheel):
    with zipfile.ZipFile(wheel) as archive:
        (meta_name,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        metadata = email.parser.Parser().parsestr(archive.read(meta_name).decode())
    requires = metadata.get_all("Requires-Dist") or []
    runtime = [r for r in requires if "extra ==" not in r]
    assert any(r.startswith("jax") for r in runtime), runtime
    assert not [r for r in runtime if NOTEBOOK_TOOLS.match(r)], runtime
    extras = [r for r in requires if "extra == " in r and NOTEBOOK_TOOLS.match(r)]
    assert any("jupyterlab" in r for r in extras), requires


def test_wheel_installs_and_reads_its_data_outside_the_checkout(wheel, tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    site = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    (pathlib.Path(site) / "zz_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", site, str(wheel)],
        check=True,
        capture_output=True,
        text=True,
    )

    def installed(*args):  # the venv's python, outside the checkout, without PYTHONPATH
        run = subprocess.run(
            [str(python), *args],
            cwd=tmp_path,
            env=CLEAN_ENV,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stdout + run.stderr
        return run.stdout

    assert installed("-c", SMOKE).strip().endswith("ok")
    # A student's first step after `pip install gfxlab[lab]`: the labs, copied by the CLI.
    copied = tmp_path / "my_labs"
    out = installed("-m", "gfxlab", "labs", "--copy", str(copied))
    names = sorted(p.name for p in copied.glob("*.ipynb"))
    assert len(names) >= 10 and all(n[:2].isdigit() for n in names), names
    assert f"copied {len(names)} labs" in out, out
