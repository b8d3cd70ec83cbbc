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


def _alternate(fns, *, repeat: int, warmup: int = 1) -> list[tuple[float, float]]:
    """(median, fastest) wall times of each of `fns`, called in turn `repeat` times (all
    see the same machine state: on a shared VM speed drifts by tens of percent over
    seconds, and on an oversubscribed one XLA's multi-threaded loops wait for descheduled
    threads, so the fastest run is the steadier measure of the code)."""
    for fn in fns:
        for _ in range(warmup):
            jax.block_until_ready(fn())
    times = [[] for _ in fns]
    for _ in range(repeat):
        for fn, out in zip(fns, times, strict=True):
            start = time.perf_counter()
            jax.block_until_ready(fn())
            out.append(time.perf_counter() - start)
    return [(statistics.median(t), min(t)) for t in times]


def _bspline_case(table: Table, dtype, modules, *, count=100, degree=3, dim=2, repeat=15):
    """`modules`: `{label: gfxlab.curves module}` (before/after), timed alternately with
    SciPy, eagerly and inside a user's `jax.jit`."""
    import scipy.interpolate as si

    rng = np.random.default_rng(0)
    cp = rng.normal(size=(count, dim))
    knots = np.asarray(curves.clamped_knots(count, degree))
    u = np.sort(rng.uniform(0, 1, 1_000_000))
    reference = si.BSpline(knots, cp, degree)
    cp_j, knots_j, u_j = (jnp.asarray(a, dtype=dtype) for a in (cp, knots, u))
    name = jnp.dtype(dtype).name
    for how in ("eager", "inside jax.jit"):
        runs = {}
        for label, module in modules.items():

            def run(c, t, s, module=module):
                return module.bspline(c, degree, s, knots=t)

            runs[label] = jax.jit(run) if how != "eager" else run
        calls = [lambda run=run: run(cp_j, knots_j, u_j) for run in runs.values()]
        *ours, ref = _alternate([*calls, lambda: reference(u)], repeat=repeat)
        for (label, run), mine in zip(runs.items(), ours, strict=True):
            error = np.abs(np.asarray(run(cp_j, knots_j, u_j), np.float64) - reference(u)).max()
            table.add(
                f"{label}cubic B-spline, {count} cp, 10^6 u, d={dim}, {name}, {how}",
                mine[0],
                ref[0],
                f"fastest runs: {1e3 * mine[1]:.1f} vs {1e3 * ref[1]:.1f} ms, "
                f"{ref[1] / mine[1]:.2f}x; max |ours - scipy| = {error:.1e}",
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
    center, radii = jnp.zeros(2), jnp.array([2.0, 1.0])
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
        "ellipse": lambda: curves.ellipse(center, radii, 0.3, u),
        "circle": lambda: curves.circle(center, 1.5, u),
        "bezier_patch": lambda: curves.bezier_patch(net, u, u),
        "patch_mesh": lambda: curves.patch_mesh(net, 4),
        "chord_length_parameters": lambda: curves.chord_length_parameters(cp),
    }


def _overhead_table() -> Table:
    """Eager call vs the same call inside `jax.jit` (a closure over constants, so the
    jitted program does the same work) at a small size: the difference is the eager
    fixed overhead (checks in Python, one compiled call). Each is the fastest of 300
    alternated calls: on a loaded machine, medians of 0.1 ms calls measure the
    scheduler rather than the code."""
    table = Table("curves: eager fixed overhead at a small size (target <= 0.1 ms)", "jax.jit")
    for name, call in _small_calls().items():
        jitted = jax.jit(call)
        times = ([], [])
        for fn in (call, jitted):
            for _ in range(3):
                jax.block_until_ready(fn())
        for _ in range(300):
            for fn, out in zip((call, jitted), times, strict=True):
                start = time.perf_counter()
                jax.block_until_ready(fn())
                out.append(time.perf_counter() - start)
        eager, jit = min(times[0]), min(times[1])
        table.add(name, eager, jit, f"overhead {1e6 * (eager - jit):.0f} us")
    return table


def main() -> None:
    table = Table(
        "curves: gfxlab (eager and inside jax.jit) vs SciPy BSpline / bezier package", "reference"
    )
    baseline = _baseline_curves()
    modules = {"": curves}
    if baseline is not None:
        revision = os.environ["CURVES_BASELINE"]
        modules = {f"before ({revision}): ": baseline, "after: ": curves}
    for dtype in (jnp.float64, jnp.float32):
        _bspline_case(table, dtype, modules)
    _bezier_case(table)
    table.print()
    _overhead_table().print()
    print(f"\n(device: {jax.devices()[0].device_kind}, {jax.device_count()} device(s))")


if __name__ == "__main__":
    main()
