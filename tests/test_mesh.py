"""Meshes: procedural shapes, normals, OBJ files and the shipped model."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from gfxlab import mesh as M
from gfxlab import transforms as tf


def signed_volume(mesh):
    t = np.asarray(mesh.triangles())
    return np.einsum("fi,fi->f", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6


def is_closed_manifold(mesh):
    f = np.asarray(mesh.faces)
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    directed = set(map(tuple, edges))
    return len(directed) == len(edges) and all((b, a) in directed for a, b in edges)


@pytest.mark.parametrize(
    "make", [M.cube, lambda: M.icosphere(2), lambda: M.cylinder(0.7, 1.5, 20)],
    ids=["cube", "icosphere", "cylinder"],
)
def test_convex_meshes_are_closed_outward_and_match_their_hull(make):
    mesh = make()
    assert is_closed_manifold(mesh)
    hull = ConvexHull(np.asarray(mesh.vertices))  # independent volume
    assert signed_volume(mesh) == pytest.approx(hull.volume, rel=1e-9)


def test_nonconvex_meshes_are_closed_with_the_right_volume():
    torus = M.torus(1.0, 0.3, 48, 24)
    assert is_closed_manifold(torus)
    # a polygonal torus: (cross-section polygon area) x (mean path of its centroid) ~
    assert signed_volume(torus) == pytest.approx(2 * np.pi**2 * 0.3**2, rel=0.02)
    pawn = M.pawn()
    assert is_closed_manifold(pawn)
    assert signed_volume(pawn) > 0
    lo, hi = np.asarray(pawn.vertices).min(0), np.asarray(pawn.vertices).max(0)
    assert lo[1] == 0 and 1.8 < hi[1] < 2.0  # stands on y = 0, about 2 units tall


def test_icosphere_counts_and_radius():
    for n in range(3):
        sphere = M.icosphere(n, radius=2.0)
        assert sphere.num_faces == 20 * 4**n
        assert sphere.num_vertices == 10 * 4**n + 2  # Euler: V - E + F = 2
        np.testing.assert_allclose(np.linalg.norm(sphere.vertices, axis=1), 2.0)


def test_normals():
    sphere = M.icosphere(2)
    centroids = sphere.triangles().mean(1)
    assert jnp.all(jnp.sum(sphere.face_normals() * centroids, -1) > 0)
    np.testing.assert_allclose(sphere.vertex_normals(), sphere.vertices, atol=0.03)
    np.testing.assert_allclose(jnp.linalg.norm(sphere.face_normals(), axis=-1), 1.0)
    cube = M.cube()
    normals = np.asarray(cube.face_normals())
    expected = np.repeat(np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1],
                                   [0, 0, 1]]), 1, axis=0)
    np.testing.assert_allclose(normals[:6], expected, atol=1e-12)
    np.testing.assert_allclose(normals[6:], expected, atol=1e-12)


def test_normals_of_degenerate_faces_have_finite_gradients():
    v = jnp.array([[0.0, 0, 0], [0, 0, 0], [1, 0, 0]])
    f = jnp.array([[0, 1, 2]])
    n = M.face_normals(v, f)
    assert jnp.all(n == 0)
    g = jax.jit(jax.grad(lambda v: jnp.sum(M.face_normals(v, f) + M.vertex_normals(v, f))))(v)
    assert jnp.all(jnp.isfinite(g))


def test_transform_and_colors():
    cube = M.cube()
    moved = cube.transform(tf.translate(jnp.array([1.0, 2.0, 3.0])))
    np.testing.assert_allclose(moved.vertices, cube.vertices + jnp.array([1.0, 2.0, 3.0]))
    red = cube.with_colors(jnp.array([1.0, 0.0, 0.0]))
    assert red.colors.shape == (8, 3)
    # a Mesh is a pytree: jit and grad through its vertices
    area = jax.jit(lambda m: jnp.sum(jnp.linalg.norm(jnp.cross(
        m.triangles()[:, 1] - m.triangles()[:, 0], m.triangles()[:, 2] - m.triangles()[:, 0]),
        axis=-1)) / 2)
    assert float(area(cube)) == pytest.approx(6.0)


def test_obj_round_trip(tmp_path):
    mesh = M.icosphere(1).with_colors(jnp.array([0.25, 0.5, 0.75]))
    path = tmp_path / "sphere.obj"
    M.write_obj(path, mesh, comment="test")
    back = M.read_obj(path)
    np.testing.assert_allclose(back.vertices, mesh.vertices, atol=5e-7)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    np.testing.assert_allclose(back.colors, mesh.colors, atol=5e-7)


def test_read_obj_polygons_and_index_forms(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text(
        "# a unit square as one quad, with texture and normal indices\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n"
        "g square\nusemtl none\nf 1/1/1 2/1/1 3//1 -1\n"
    )
    mesh = M.read_obj(path)
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3]])
    assert mesh.colors is None


def test_shipped_model_is_what_the_code_writes(tmp_path):
    shipped = M.shipped_model_path("pawn.obj")
    assert shipped.exists()
    (written,) = M.write_shipped_models(tmp_path)
    ours, theirs = written.read_text().splitlines(), shipped.read_text().splitlines()
    assert len(ours) == len(theirs)
    # the same statements; numbers equal up to the last printed digit (libm may differ)
    for a, b in zip(ours, theirs, strict=True):
        if a.startswith("v "):
            np.testing.assert_allclose(np.array(a.split()[1:], float),
                                       np.array(b.split()[1:], float), atol=1.5e-6)
        else:
            assert a == b
    pawn = M.read_obj(shipped)
    np.testing.assert_allclose(pawn.vertices, M.pawn().vertices, atol=5e-7)


def test_bad_inputs(tmp_path):
    with pytest.raises(ValueError, match="faces"):
        M.Mesh(jnp.zeros((3, 3)), jnp.array([[0, 1, 3]]))
    with pytest.raises(TypeError, match="faces"):
        M.Mesh(jnp.zeros((3, 3)), jnp.array([[0.0, 1.0, 2.0]]))
    with pytest.raises(ValueError, match="vertices"):
        M.Mesh(jnp.zeros((3, 2)), jnp.array([[0, 1, 2]]))
    with pytest.raises(ValueError, match="colors"):
        M.Mesh(jnp.zeros((3, 3)), jnp.array([[0, 1, 2]]), jnp.zeros((2, 3)))
    with pytest.raises(ValueError, match="subdivisions"):
        M.icosphere(-1)
    with pytest.raises(ValueError, match="profile"):
        M.revolve(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="name"):
        M.shipped_model_path("teapot.obj")
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0\n")
    with pytest.raises(ValueError, match="line 1"):
        M.read_obj(bad)
    bad.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
    with pytest.raises(ValueError, match="does not exist"):
        M.read_obj(bad)
    with pytest.raises(TypeError, match="mesh"):
        M.write_obj(bad, "not a mesh")
