"""Curves: a cubic B-spline with 100 control points at 10^6 parameters, jitted, against
SciPy's `BSpline.__call__` in the same run, in float64 and float32; plus Bezier and
Bernstein evaluation against the `bezier` package."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from harness import Table, timeit_pair

jax.config.update("jax_enable_x64", True)

from gfxlab import curves  # noqa: E402


def _bspline_case(table: Table, dtype, *, count=100, degree=3, samples=1_000_000, dim=2):
    import scipy.interpolate as si

    rng = np.random.default_rng(0)
    cp = rng.normal(size=(count, dim))
    knots = np.asarray(curves.clamped_knots(count, degree))
    u = np.sort(rng.uniform(0, 1, samples))
    reference = si.BSpline(knots, cp, degree)
    cp_j, knots_j, u_j = (jnp.asarray(a, dtype=dtype) for a in (cp, knots, u))
    name = jnp.dtype(dtype).name
    # `curves.bspline` is one compiled program (span search in a `lax.fori_loop`, then the
    # evaluation), the same whether called eagerly or inside a user's `jax.jit`. Ours and
    # SciPy are timed alternately, so both see the same machine state.
    for how, run in [
        ("eager", lambda c, t, s: curves.bspline(c, degree, s, knots=t)),
        ("inside jax.jit", jax.jit(lambda c, t, s: curves.bspline(c, degree, s, knots=t))),
    ]:
        ours, ref = timeit_pair(
            lambda run=run: run(cp_j, knots_j, u_j), lambda: reference(u), repeat=9, warmup=1
        )
        error = np.abs(np.asarray(run(cp_j, knots_j, u_j), np.float64) - reference(u)).max()
        table.add(
            f"cubic B-spline, {count} cp, 10^6 u, d={dim}, {name}, {how}",
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
    run = jax.jit(curves.bezier)
    nodes_j, u_j = jnp.asarray(nodes), jnp.asarray(u)
    ours, ref = timeit_pair(
        lambda: run(nodes_j, u_j), lambda: curve.evaluate_multi(u), repeat=7, warmup=1
    )
    table.add("degree-7 Bezier, 10^5 u, d=3, float64", ours, ref, "bezier.Curve.evaluate_multi")


def main() -> None:
    table = Table(
        "curves: gfxlab (eager and inside jax.jit) vs SciPy BSpline / bezier package", "reference"
    )
    for dtype in (jnp.float64, jnp.float32):
        _bspline_case(table, dtype)
    _bezier_case(table)
    table.print()
    print(f"\n(device: {jax.devices()[0].device_kind}, {jax.device_count()} device(s))")


if __name__ == "__main__":
    main()
