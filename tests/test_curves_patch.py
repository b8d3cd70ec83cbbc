"""gfxlab.curves: tensor-product Bezier patches, patch meshes and the Utah teapot."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from gfxlab import curves
from gfxlab.mesh import Mesh


def test_bezier_patch_is_a_curve_of_curves():
    rng = np.random.default_rng(0)
    net = rng.normal(size=(4, 3, 3))  # bicubic in u, quadratic in v
    u, v = np.linspace(0, 1, 5), np.array([0.0, 0.3, 1.0])
    surface = np.asarray(curves.bezier_patch(net, u, v))
    assert surface.shape == (5, 3, 3)
    # Evaluate each column curve at u, then the resulting curves at v (de Casteljau).
    columns = np.stack(
        [np.asarray(curves.de_casteljau(net[:, j], u)[-1])[:, 0] for j in range(3)], axis=1
    )  # (U, n+1, d)
    expected = np.stack([np.asarray(curves.bezier(columns[a], v)) for a in range(5)])
    np.testing.assert_allclose(surface, expected, atol=1e-14)
    np.testing.assert_allclose(
        surface[[0, 0, -1, -1], [0, -1, 0, -1]], net[[0, 0, -1, -1], [0, -1, 0, -1]], atol=1e-15
    )
    check_grads(
        jax.jit(curves.bezier_patch), (jnp.asarray(net), u[1:4], v[1:2]), order=1, modes=["rev"]
    )


def test_patch_mesh_grid_and_winding():
    # A flat square patch in z = 0 with u along x and v along y: dS/du x dS/dv = +z.
    x, y = np.meshgrid(np.linspace(0, 1, 4), np.linspace(0, 1, 4), indexing="ij")
    net = np.stack([x, y, np.zeros_like(x)], axis=-1)
    mesh = curves.patch_mesh(net, 3)
    assert isinstance(mesh, Mesh)
    vertices, faces = mesh.vertices, mesh.faces
    assert vertices.shape == (16, 3) and faces.shape == (18, 3) and faces.dtype == jnp.int32
    tri = np.asarray(vertices)[np.asarray(faces)]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(normals[:, :2], 0, atol=1e-15)
    assert np.all(normals[:, 2] > 0)
    np.testing.assert_allclose(0.5 * normals[:, 2].sum(), 1.0)  # the triangles tile the square
    # Several patches: indices stay within their own patch's block.
    both = curves.patch_mesh(np.stack([net, net + 1]), 2)
    assert both.vertices.shape == (18, 3) and both.faces.shape == (16, 3)
    assert np.asarray(both.faces)[8:].min() >= 9


def test_teapot_data_and_mesh():
    patches = curves.teapot_patches()
    assert patches.shape == (32, 4, 4, 3)
    # 306 published control points (some appear in several patches).
    assert len(np.unique(np.asarray(patches).reshape(-1, 3), axis=0)) <= 306
    np.testing.assert_allclose(np.asarray(patches).reshape(-1, 3).min(axis=0), [-3, -2, 0])
    np.testing.assert_allclose(np.asarray(patches).reshape(-1, 3).max(axis=0), [3.525, 2, 3.15])
    mesh = curves.teapot(resolution=4)
    assert isinstance(mesh, Mesh)
    vertices, faces = mesh.vertices, mesh.faces
    assert vertices.shape == (32 * 25, 3) and faces.shape == (32 * 32, 3)
    v, f = np.asarray(vertices), np.asarray(faces)
    # Neighbouring patches meet: rim patch 0's edge u = 1 is body patch 4's edge u = 0.
    np.testing.assert_allclose(v[20:25], v[100:105], atol=1e-12)
    # Outward winding: body, lid and bottom (patches 0-11, 20-31) enclose a positive volume.
    closed = np.concatenate([np.arange(0, 12), np.arange(20, 32)])
    shell = f.reshape(32, -1, 3)[closed].reshape(-1, 3)
    tri = v[shell]
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert 20 < volume < 30  # roughly a squat cylinder of radius ~1.8 and height ~2.5


def test_patch_bad_input():
    with pytest.raises(ValueError, match="control_net"):
        curves.bezier_patch(jnp.zeros((4, 3)), jnp.array([0.5]), jnp.array([0.5]))
    with pytest.raises(ValueError, match="`v` must lie in \\[0, 1\\]"):
        curves.bezier_patch(jnp.zeros((4, 4, 3)), jnp.array([0.5]), jnp.array([1.5]))
    with pytest.raises(ValueError, match="`resolution` must be >= 1"):
        curves.patch_mesh(jnp.zeros((4, 4, 3)), 0)
    with pytest.raises(ValueError, match="control_nets"):
        curves.patch_mesh(jnp.zeros((4, 3)), 2)
    with pytest.raises(TypeError, match="`resolution` must be an int"):
        curves.teapot(2.5)
