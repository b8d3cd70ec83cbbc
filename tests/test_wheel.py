"""The wheel is whole: built from the checkout, installed outside it, every data file found.

The wheel goes into a fresh virtual environment in a temporary directory. Its
dependencies are not downloaded again: the environment sees the test run's own
site-packages through a `.pth` path entry (appended after the wheel's own folder, and
without running that folder's `.pth` hooks, so the checkout's editable install stays
out of sight). The smoke test then runs from a directory outside the checkout and
checks that gfxlab was imported from the wheel.
"""

import pathlib
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
from gfxlab import _resources, color, curves, image, mesh
assert color.cmfs().shape[-1] == 3
assert color.illuminant_d65()[0].shape[0] > 50
teapot = curves.teapot()
pawn = mesh.read_obj(mesh.shipped_model_path("pawn.obj"))
scene = image.read_image(_resources.data_file("images", "scene.png"))
assert scene.ndim == 3, scene.shape
labs = sorted(p.name for p in _resources.labs_dir().glob("[0-9]*.ipynb"))
assert len(labs) >= 10, labs
assert not (_resources.labs_dir() / "assignments").exists(), "assignment sources shipped"
with tempfile.TemporaryDirectory() as tmp:
    assert len(_resources.copy_labs(tmp)) == len(labs)
print("ok")
"""


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> pathlib.Path:
    out = tmp_path_factory.mktemp("wheel")
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
            str(ROOT),
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
    run = subprocess.run(
        [str(python), "-c", SMOKE], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stdout + run.stderr
    assert run.stdout.strip().endswith("ok")
