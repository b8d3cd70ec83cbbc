"""MkDocs hook: put the labs that `make test` executed into the site.

The executed notebooks live in `$GFXLAB_LABS_OUT` (default `build/labs`); they are
copied into `docs/labs/` (ignored by git) before MkDocs collects its files, so the lab
pages show every figure without running a notebook again.
"""

import os
import pathlib
import shutil

ROOT = pathlib.Path(__file__).resolve().parents[1]


def on_pre_build(config, **kwargs):
    source = pathlib.Path(os.environ.get("GFXLAB_LABS_OUT", ROOT / "build" / "labs"))
    target = ROOT / "docs" / "labs"
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    for notebook in sorted(source.glob("[0-9]*.ipynb")):
        shutil.copyfile(notebook, target / notebook.name)
