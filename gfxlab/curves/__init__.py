"""Curves and surfaces: Bezier, de Casteljau, B-splines (Cox-de Boor), NURBS, the
parametric ellipse, tensor-product Bezier patches and the Utah teapot.

Conventions:

- Control points are arrays `(..., n+1, d)` (leading batch dimensions allowed); a
  curve evaluated at parameters `u` of shape `(N,)` gives points `(..., N, d)`. A
  scalar `u` drops the `N` axis; any other shape `U` gives `(..., *U, d)`.
- Degrees and counts are static Python ints; control points, weights, knots and
  parameters are traced and differentiable.
- A Bezier curve lives on `0 <= u <= 1`. A B-spline of degree `p` with knots
  `t_0 <= ... <= t_m` and `n = m - p` control points lives on `t_p <= u <= t_n`
  (`parameter_range`). Parameters outside the range raise `ValueError` (at once for
  concrete values, through `equinox.error_if` under `jit`). A closed B-spline
  (`closed=True`) is periodic: any finite `u` is taken modulo its period.
- NaN/inf inputs, `None` and oversized static sizes (`MAX_DEGREE`, `MAX_BSPLINE_DEGREE`,
  `MAX_CONTROL_POINTS`, `MAX_RESOLUTION`) are clear errors naming the argument.

Examples:
    >>> import jax.numpy as jnp
    >>> from gfxlab import curves
    >>> abcd = jnp.array([[1, 1], [2, 3], [4, 3], [6, 4.0]])
    >>> curves.bezier(abcd, jnp.array([0.25, 0.5])).tolist()  # the exam's question
    [[1.921875, 2.171875], [3.125, 2.875]]
    >>> curves.bernstein(3, jnp.array([0.5])).tolist()
    [[0.125, 0.375, 0.375, 0.125]]

Package layout (private modules, one concept each): `_bezier` (the Bernstein basis,
Bezier curves), `_knots` (knot vectors, span search, periodic breakpoints), `_bspline`,
`_nurbs`, `_conics` (ellipse, circle), `_patches` (Bezier patches, the teapot as a
`gfxlab.mesh.Mesh`), `_fitting`; everything public is imported here.
"""

from __future__ import annotations

from ._bezier import Bezier, bernstein, bezier, de_casteljau, derivative, elevate_degree, split
from ._bspline import BSpline, bspline, bspline_basis
from ._common import MAX_BSPLINE_DEGREE, MAX_CONTROL_POINTS, MAX_DEGREE, MAX_RESOLUTION
from ._conics import Ellipse, circle, ellipse
from ._fitting import chord_length_parameters, fit_bezier, fit_bspline, fit_ellipse
from ._knots import clamped_knots, parameter_range, periodic_breakpoints, uniform_knots
from ._nurbs import NURBS, nurbs, nurbs_circle
from ._patches import bezier_patch, patch_mesh, teapot, teapot_patches

__all__ = [
    # Bezier
    "bernstein",
    "bezier",
    "de_casteljau",
    "split",
    "elevate_degree",
    "derivative",
    # B-splines and NURBS
    "uniform_knots",
    "clamped_knots",
    "parameter_range",
    "periodic_breakpoints",
    "bspline_basis",
    "bspline",
    "nurbs",
    "nurbs_circle",
    # conics
    "ellipse",
    "circle",
    # surfaces
    "bezier_patch",
    "patch_mesh",
    "teapot_patches",
    "teapot",
    # modules
    "Bezier",
    "BSpline",
    "NURBS",
    "Ellipse",
    # fitting
    "chord_length_parameters",
    "fit_bezier",
    "fit_bspline",
    "fit_ellipse",
    # size limits
    "MAX_DEGREE",
    "MAX_BSPLINE_DEGREE",
    "MAX_CONTROL_POINTS",
    "MAX_RESOLUTION",
]
