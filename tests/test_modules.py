"""The parametric `equinox.Module`s as pytrees (docs/architecture.md, "Validating a Module").

Converters and `__check_init__` run when a Module is constructed, not when JAX rebuilds it
from its leaves (`jit`, `vmap`, `eqx.tree_at`, each iterate of `gfxlab.fit`); a Module built
inside `jit` from traced values equals the one built eagerly.
"""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gfxlab
from gfxlab import curves, mesh, raster, render, viewing

CP = [[0.0, 0.0], [1.0, 2.0], [2.0, 0.0], [3.0, 1.0]]

MODULES = {
    "Mesh": lambda v: mesh.Mesh(v, jnp.array([[0, 1, 2]]), jnp.full((3, 3), 0.5)),
    "BSpline": lambda v: curves.BSpline(v[:, :2], 2, fit_knots=True),
    "BSpline closed": lambda v: curves.BSpline(v[:, :2], 2, closed=True),
    "NURBS": lambda v: curves.NURBS(v[:, :2], jnp.ones(3), 2),
    "Bezier": lambda v: curves.Bezier(v),
    "Ellipse": lambda v: curves.Ellipse(v[0, :2], v[1, :2] + 1.0, v[2, 0]),
    "Camera": lambda v: viewing.Camera(v[0] + 5.0, fov_y=0.5 + v[1, 1]),
    "Camera rotation": lambda v: viewing.Camera(v[0] + 5.0, rotation=v[1]),
    "VisibilityResult": lambda v: render.VisibilityResult(v[:, :, None], v, {"memory_bytes": 1}),
    "PointLight": lambda v: render.PointLight(v[0], v[1, 1]),
    "DirectionalLight": lambda v: render.DirectionalLight(v[0] + 1.0),
    "BeamPath": lambda v: raster.BeamPath(v[:, :2], v[:, 2], v[:, 2] > 0),
}
VALUES = jnp.array([[0.1, 0.2, 0.3], [0.4, 0.5, 0.6], [0.7, 0.8, 0.9]])


def _same(a, b):
    leaves_a, tree_a = jax.tree_util.tree_flatten(a)
    leaves_b, tree_b = jax.tree_util.tree_flatten(b)
    assert tree_a == tree_b
    for x, y in zip(leaves_a, leaves_b, strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12)


@pytest.mark.parametrize("name", list(MODULES))
def test_rebuilding_from_leaves_runs_no_validation(name, monkeypatch):
    module = MODULES[name](VALUES)
    cls = type(module)
    runs = []
    for klass in cls.__mro__:
        if "__check_init__" in klass.__dict__:
            original = klass.__dict__["__check_init__"]
            monkeypatch.setattr(klass, "__check_init__", lambda self, f=original: runs.append(f))
    converters = [
        f.metadata["converter"] for f in dataclasses.fields(cls) if "converter" in f.metadata
    ]
    assert converters, "every Module here converts its array fields"
    leaves, tree = jax.tree_util.tree_flatten(module)
    _same(jax.tree_util.tree_unflatten(tree, leaves), module)
    _same(jax.jit(lambda m: m)(module), module)
    stacked = jax.tree.map(lambda x: jnp.stack([x, x]), module)
    _same(jax.vmap(lambda m: m)(stacked), stacked)
    moved = eqx.tree_at(lambda m: jax.tree_util.tree_leaves(m)[0], module, replace_fn=lambda x: x)
    _same(moved, module)
    assert runs == []
    MODULES[name](VALUES)  # construction does run them (the patch is live)
    assert len(runs) == sum("__check_init__" in k.__dict__ for k in cls.__mro__)


@pytest.mark.parametrize("name", list(MODULES))
def test_built_under_jit_equals_built_eagerly(name):
    _same(jax.jit(MODULES[name])(VALUES), MODULES[name](VALUES))


def test_traced_field_checks_under_jit_and_relations_where_the_fields_are_used():
    faces = jnp.array([[0, 1, 2]])
    with pytest.raises(ValueError, match=r"^`colors` must be in \[0, 1\]"):
        gfxlab.checked_jit(lambda c: mesh.Mesh(jnp.eye(3), faces, c).colors)(jnp.full((3, 3), 2.0))
    with pytest.raises(ValueError, match=r"^`faces` must index the 3 vertices"):
        gfxlab.checked_jit(lambda f: mesh.Mesh(jnp.eye(3), f).face_normals())(faces + 3)
    with pytest.raises(ValueError, match=r"^`target` equals `eye`"):
        gfxlab.checked_jit(lambda e: viewing.Camera(e).matrix())(jnp.zeros(3))
    # eagerly the relations are checked at construction
    with pytest.raises(ValueError, match=r"^`faces` must index the 3 vertices"):
        mesh.Mesh(jnp.eye(3), faces + 3)
    with pytest.raises(ValueError, match="`far` must be greater than `near`"):
        viewing.Camera([0.0, 0.0, 5.0], near=2.0, far=1.0)
    with pytest.raises(ValueError, match=r"^`depth` must have shape"):
        render.VisibilityResult(jnp.zeros((2, 2, 3)), jnp.zeros((3, 2)), {})


def test_fit_moves_a_module_without_rebuilding_it():
    u = jnp.linspace(0.0, 1.0, 30)
    target = curves.BSpline(jnp.array(CP), 2)(u)
    start = curves.BSpline(jnp.array(CP) + 0.3, 2, fit_knots=True)
    result = gfxlab.fit.fit(lambda s: s(u) - target, start)
    assert isinstance(result.params, curves.BSpline) and result.params.fit_knots
    np.testing.assert_allclose(result.params(u), target, atol=1e-6)
