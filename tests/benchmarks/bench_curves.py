"""Curves: a cubic B-spline with 100 control points at 10^6 parameters against SciPy's
`BSpline.__call__` in the same run (float64 and float32), eagerly and inside a user's
`jax.jit`; the eager fixed overhead of every public curve function at a small size;
Bezier evaluation against the `bezier` package.

`CURVES_BASELINE=<git revision>` (e.g. `main`) also times that revision's `gfxlab.curves`
(extracted with `git archive` and imported as `gfxlab_baseline`) in the same run, so the
table shows before and after side by side, each against SciPy timed alternately with it.
"""

from __future__ import annotations

import importlib
import io
import os
import pathlib
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit_pair

jax.config.update("jax_enable_x64", True)

from gfxlab import curves  # noqa: E402


def _baseline_curves():
    """`gfxlab.curves` of the revision `CURVES_BASELINE`, or None."""
    revision = os.environ.get("CURVES_BASELINE")
    if not revision:
        return None
    root = pathlib.Path(__file__).resolve().parents[2]
    archive = subprocess.run(
        ["git", "-C", str(root), "archive", revision, "gfxlab"], capture_output=True, check=True
    ).stdout
    folder = pathlib.Path(tempfile.mkdtemp(prefix="curves_baseline_"))
    tarfile.open(fileobj=io.BytesIO(archive)).extractall(folder, filter="data")
    (folder / "gfxlab").rename(folder / "gfxlab_baseline")
    sys.path.insert(0, str(folder))
    return importlib.import_module("gfxlab_baseline.curves")


def _bspline_case(table: Table, dtype, module, label, *, count=100, degree=3, dim=2):
    import scipy.interpolate as si

    rng = np.random.default_rng(0)
    cp = rng.normal(size=(count, dim))
    knots = np.asarray(curves.clamped_knots(count, degree))
    u = np.sort(rng.uniform(0, 1, 1_000_000))
    reference = si.BSpline(knots, cp, degree)
    cp_j, knots_j, u_j = (jnp.asarray(a, dtype=dtype) for a in (cp, knots, u))
    name = jnp.dtype(dtype).name
    # Ours and SciPy are timed alternately, so both see the same machine state.
    for how, run in [
        ("eager", lambda c, t, s: module.bspline(c, degree, s, knots=t)),
        ("inside jax.jit", jax.jit(lambda c, t, s: module.bspline(c, degree, s, knots=t))),
    ]:
        ours, ref = timeit_pair(
            lambda run=run: run(cp_j, knots_j, u_j), lambda: reference(u), repeat=9, warmup=1
        )
        error = np.abs(np.asarray(run(cp_j, knots_j, u_j), np.float64) - reference(u)).max()
        table.add(
            f"{label}cubic B-spline, {count} cp, 10^6 u, d={dim}, {name}, {how}",
            ours,
            ref,
            f"max |ours - scipy| = {error:.1e}",
        )


def _bezier_case(table: Table):
    import bezier as bezier_pkg

    rng = np.random.default_rng(1)
    nodes = rng.normal(size=(8, 3))
    u = rng.uniform(0, 1, 100_000)
    curve = bezier_pkg.Curve(nodes.T, degree=7)
    nodes_j, u_j = jnp.asarray(nodes), jnp.asarray(u)
    ours, ref = timeit_pair(
        lambda: curves.bezier(nodes_j, u_j), lambda: curve.evaluate_multi(u), repeat=7, warmup=1
    )
    table.add("degree-7 Bezier, 10^5 u, d=3, float64, eager", ours, ref, "bezier.Curve")


def _small_calls():
    """(name, eager call) of every public array function at a small size."""
    cp = jnp.asarray(np.random.default_rng(2).normal(size=(6, 2)))
    u = jnp.array([0.1, 0.5, 0.9])
    knots = curves.clamped_knots(6, 3)
    net = curves.teapot_patches()[:2]
    weights = jnp.ones(6)
    return {
        "bernstein": lambda: curves.bernstein(3, u),
        "bezier": lambda: curves.bezier(cp, u),
        "de_casteljau": lambda: curves.de_casteljau(cp, u),
        "split": lambda: curves.split(cp, 0.3),
        "elevate_degree": lambda: curves.elevate_degree(cp, times=2),
        "derivative": lambda: curves.derivative(cp),
        "parameter_range": lambda: curves.parameter_range(knots, 3),
        "bspline_basis": lambda: curves.bspline_basis(knots, 3, u),
        "bspline": lambda: curves.bspline(cp, 3, u),
        "bspline closed": lambda: curves.bspline(cp, 3, u, closed=True),
        "nurbs": lambda: curves.nurbs(cp, weights, 3, u),
        "ellipse": lambda: curves.ellipse(jnp.zeros(2), jnp.array([2.0, 1.0]), 0.3, u),
        "circle": lambda: curves.circle(jnp.zeros(2), 1.5, u),
        "bezier_patch": lambda: curves.bezier_patch(net, u, u),
        "patch_mesh": lambda: curves.patch_mesh(net, 4),
        "chord_length_parameters": lambda: curves.chord_length_parameters(cp),
    }


def _overhead_table() -> Table:
    """Eager call vs the same call inside `jax.jit` (a closure over constants, so the
    jitted program does the same work) at a small size: the difference is the eager
    fixed overhead (checks in Python, one compiled call)."""
    table = Table("curves: eager fixed overhead at a small size (target <= 0.1 ms)", "jax.jit")
    for name, call in _small_calls().items():
        jitted = jax.jit(call)
        eager_times, jit_times = [], []
        for _ in range(3):
            jax.block_until_ready(call())
            jax.block_until_ready(jitted())
        for _ in range(200):
            for fn, out in ((call, eager_times), (jitted, jit_times)):
                start = time.perf_counter()
                jax.block_until_ready(fn())
                out.append(time.perf_counter() - start)
        eager, jit = statistics.median(eager_times), statistics.median(jit_times)
        table.add(name, eager, jit, f"overhead {1e6 * (eager - jit):.0f} us")
    return table


def main() -> None:
    table = Table(
        "curves: gfxlab (eager and inside jax.jit) vs SciPy BSpline / bezier package", "reference"
    )
    baseline = _baseline_curves()
    for dtype in (jnp.float64, jnp.float32):
        if baseline is not None:
            revision = os.environ["CURVES_BASELINE"]
            _bspline_case(table, dtype, baseline, f"before ({revision}): ")
        _bspline_case(table, dtype, curves, "after: " if baseline is not None else "")
    _bezier_case(table)
    table.print()
    _overhead_table().print()
    print(f"\n(device: {jax.devices()[0].device_kind}, {jax.device_count()} device(s))")


if __name__ == "__main__":
    main()
