"""Run a script in a child Python with the user's XLA flags instead of the suite's.

The suite compiles with fast-compile flags (tests/conftest.py): LLVM at -O0, XLA's
legacy CPU emitters. Whatever depends on how a program is compiled (the rounding of
fused multiply-adds, per-program compiler options) is only seen with the flags a user
has, saved by conftest in `$GFXLAB_USER_XLA_FLAGS`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys


def run_with_user_xla_flags(script: str, *args: str):
    """Run `script` (`python -c`) with `args` on the CPU with the user's XLA flags;
    returns its last line of output, parsed as JSON. A failed run fails the test with
    the end of its stderr."""
    env = dict(os.environ, XLA_FLAGS=os.environ["GFXLAB_USER_XLA_FLAGS"], JAX_PLATFORMS="cpu")
    out = subprocess.run(
        [sys.executable, "-c", script, *args], env=env, capture_output=True, text=True, timeout=600
    )
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])
