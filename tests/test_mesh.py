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
    "make",
    [M.cube, lambda: M.icosphere(2), lambda: M.cylinder(0.7, 1.5, 20)],
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
    expected = np.repeat(
        np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]]), 1, axis=0
    )
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
    area = jax.jit(
        lambda m: (
            jnp.sum(
                jnp.linalg.norm(
                    jnp.cross(
                        m.triangles()[:, 1] - m.triangles()[:, 0],
                        m.triangles()[:, 2] - m.triangles()[:, 0],
                    ),
                    axis=-1,
                )
            )
            / 2
        )
    )
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
            np.testing.assert_allclose(
                np.array(a.split()[1:], float), np.array(b.split()[1:], float), atol=1.5e-6
            )
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
    # issue 17: NaN vertices, out-of-range (also -1) indices, sizes, non-numbers, binary files
    with pytest.raises(ValueError, match="vertices"):
        M.Mesh(jnp.array([[0.0, 0, 0], [1, 0, 0], [0, jnp.nan, 0]]), jnp.array([[0, 1, 2]]))
    for faces in (jnp.array([[0, 1, 3]]), jnp.array([[0, 1, -1]])):
        with pytest.raises(ValueError, match="faces"):
            M.face_normals(jnp.eye(3), faces)
        with pytest.raises(ValueError, match="faces"):
            M.vertex_normals(jnp.eye(3), faces)
        with pytest.raises(Exception, match="faces"):  # under jit too
            jax.block_until_ready(jax.jit(M.face_normals)(jnp.eye(3), faces))
    with pytest.raises(ValueError, match="subdivisions"):
        M.icosphere(100)
    with pytest.raises(TypeError, match="major_radius"):
        M.torus("abc")
    with pytest.raises(TypeError, match="size"):
        M.cube(None)
    bad.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(ValueError, match="path"):
        M.read_obj(bad)
    with pytest.raises(TypeError, match="path"):
        M.read_obj(None)
    with pytest.raises(ValueError, match="uv_faces"):
        M.Mesh(jnp.eye(3), jnp.array([[0, 1, 2]]), uvs=jnp.zeros((3, 2)))
    with pytest.raises(ValueError, match="texture"):
        M.Mesh(jnp.eye(3), jnp.array([[0, 1, 2]]), texture=jnp.ones((2, 2, 3)))


def test_read_obj_texture_coordinates_normals_and_diffuse_map(tmp_path):
    from PIL import Image

    texture = np.zeros((2, 3, 3), np.uint8)
    texture[0, :, 0] = 255  # top row red
    texture[1, :, 2] = 255  # bottom row blue
    Image.fromarray(texture).save(tmp_path / "checker.png")
    (tmp_path / "square.mtl").write_text("newmtl paint\nKd 1 1 1\nmap_Kd checker.png\n")
    (tmp_path / "square.obj").write_text(
        "mtllib square.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl paint\n"
        "f 1/1/1 2/2/1 3/3/1 4/4/1\n"
    )
    mesh = M.read_obj(tmp_path / "square.obj")
    np.testing.assert_array_equal(mesh.uv_faces, [[0, 1, 2], [0, 2, 3]])
    np.testing.assert_allclose(mesh.uvs[2], [1, 1])
    np.testing.assert_allclose(mesh.normals, [[0, 0, 1]])
    np.testing.assert_array_equal(mesh.normal_faces, np.zeros((2, 3)))
    np.testing.assert_allclose(mesh.texture, texture / 255.0)
    # written back with vt/vn and read again
    M.write_obj(tmp_path / "again.obj", mesh)
    again = M.read_obj(tmp_path / "again.obj")
    np.testing.assert_allclose(again.uvs, mesh.uvs, atol=1e-6)
    np.testing.assert_array_equal(again.uv_faces, mesh.uv_faces)
    np.testing.assert_array_equal(again.normal_faces, mesh.normal_faces)


def numpy_laplacian(v, f):
    neighbours = [[] for _ in v]
    for face in f:  # a test reference: each face contributes its two edges at a vertex
        for k in range(3):
            a, b, c = face[k], face[(k + 1) % 3], face[(k + 2) % 3]
            neighbours[a] += [b, c]
    delta = np.array([v[i] - v[n].mean(0) for i, n in enumerate(neighbours)])
    return np.mean(np.sum(delta**2, -1))


def test_mesh_losses_against_numpy():
    rng = np.random.default_rng(0)
    sphere = M.icosphere(1)
    v = np.asarray(sphere.vertices) + rng.normal(0, 0.05, sphere.vertices.shape)
    f = np.asarray(sphere.faces)
    assert float(M.laplacian_loss(jnp.asarray(v), f)) == pytest.approx(numpy_laplacian(v, f))
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    length = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=-1)
    assert float(M.edge_length_loss(jnp.asarray(v), f)) == pytest.approx(np.mean(length**2))
    assert float(M.edge_length_loss(jnp.asarray(v), f, target=0.5)) == pytest.approx(
        np.mean((length - 0.5) ** 2)
    )
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    pairs = {}
    for index, (a, b) in enumerate(edges):
        pairs.setdefault((min(a, b), max(a, b)), []).append(index % len(f))
    cos = [n[i] @ n[j] for i, j in pairs.values()]
    assert float(M.normal_consistency_loss(M.Mesh(v, f))) == pytest.approx(1 - np.mean(cos))
    # under jit (faces traced) and with gradients
    value, grad = jax.jit(
        jax.value_and_grad(lambda v, f: M.normal_consistency_loss(v, f) + M.laplacian_loss(v, f))
    )(jnp.asarray(v), f)
    assert float(value) == pytest.approx(1 - np.mean(cos) + numpy_laplacian(v, f))
    assert bool(jnp.all(jnp.isfinite(grad)))
    # a flat sheet is perfectly consistent
    sheet = M.Mesh(
        jnp.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), jnp.array([[0, 1, 2], [0, 2, 3]])
    )
    assert float(M.normal_consistency_loss(sheet)) == pytest.approx(0.0, abs=1e-12)


def test_chamfer_distance_against_scipy():
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(40, 3)), rng.normal(size=(25, 3))
    expected = np.mean(cKDTree(b).query(a)[0] ** 2) + np.mean(cKDTree(a).query(b)[0] ** 2)
    assert float(M.chamfer_distance(a, b)) == pytest.approx(expected)
    assert float(M.chamfer_distance(a, a)) == 0.0
    with pytest.raises(ValueError, match="dimension"):
        M.chamfer_distance(a, b[:, :2])
    with pytest.raises(ValueError, match="`b`"):
        M.chamfer_distance(a, np.zeros((0, 3)))
    with pytest.raises(ValueError, match="`a`"):
        M.chamfer_distance(np.full((2, 3), np.nan), b)


@pytest.mark.parametrize(
    "call, error, message",
    [
        (lambda: M.cylinder(segments=10**12), ValueError, "`segments` must be <="),
        (lambda: M.torus(major_segments=10**12), ValueError, "`major_segments` must be <="),
        (lambda: M.torus(minor_segments=10**6), ValueError, "`minor_segments` must be <="),
        (lambda: M.torus(major_segments=60_000, minor_segments=60_000), ValueError, "elements"),
        (lambda: M.pawn(segments=10**12), ValueError, "`segments` must be <="),
        (lambda: M.revolve([[0.0, 0.0], [1.0, 1.0]], segments=2**17), ValueError, "`segments`"),
        (lambda: M.revolve(None), TypeError, "`profile`"),
        (lambda: M.revolve([[0.0, 0.0], [np.nan, 1.0]]), ValueError, "`profile` must be finite"),
        (lambda: M.check_faces([[0, 1, 2]], 3, name="no-such-name"), ValueError, "`name`"),
        (lambda: M.check_faces([[0, 1, 2]], 10**12), ValueError, "`num_vertices`"),
        (lambda: M.check_faces(None, 3), TypeError, "`faces`"),
        (lambda: M.check_colors(np.ones((3, 3)), 3, per="pixel"), ValueError, "`per`"),
        (lambda: M.check_colors(np.full((3, 3), np.nan), 3), ValueError, "`colors` must be fin"),
        (lambda: M.laplacian_loss(None), TypeError, "`mesh`"),
        (lambda: M.edge_length_loss(np.zeros((3, 3))), TypeError, "`faces`"),
        (
            lambda: M.normal_consistency_loss(np.full((3, 3), np.inf), np.array([[0, 1, 2]])),
            ValueError,
            "`mesh` must be finite",
        ),
    ],
)
def test_sizes_and_arguments_are_checked(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_normals_reject_nan_vertices_eagerly_and_under_jit(maybe_jit):
    from gfxlab import check_message

    vertices = jnp.eye(3).at[1, 1].set(jnp.nan)
    for fn in (M.face_normals, M.vertex_normals):
        with pytest.raises(Exception) as info:
            jax.block_until_ready(maybe_jit(fn)(vertices, jnp.array([[0, 1, 2]])))
        assert "`vertices` must be finite" in (check_message(info.value) or "")


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda v: M.cube(v), "size"),
        (lambda v: M.icosphere(0, radius=v), "radius"),
        (lambda v: M.cylinder(radius=v, segments=3), "radius"),
        (lambda v: M.cylinder(height=v, segments=3), "height"),
        (lambda v: M.torus(v, 0.1, major_segments=3, minor_segments=3), "major_radius"),
        (lambda v: M.torus(minor_radius=v, major_segments=3, minor_segments=3), "minor_radius"),
    ],
)
def test_procedural_sizes_must_be_finite_and_positive(call, name):
    """A negative radius would build an inside-out mesh, 0 a degenerate one."""
    for bad in (-1.0, 0.0, 0, np.nan, np.inf, -np.inf, np.float32(-2.0)):
        with pytest.raises(ValueError, match=f"^`{name}` must be finite and > 0"):
            call(bad)
    with pytest.raises(TypeError, match=f"`{name}` must be a real number"):
        call("1")
    with pytest.raises(TypeError, match=f"`{name}` must be a static Python number"):
        jax.jit(call)(jnp.asarray(0.5))  # sizes are static: a traced one is refused clearly
    assert signed_volume(call(0.25)) > 0  # a small size gives an outward-facing solid


def test_torus_tube_thinner_than_its_ring_and_revolve_needs_a_radius():
    with pytest.raises(ValueError, match="`minor_radius` must be < `major_radius`"):
        M.torus(1.0, 1.0)
    with pytest.raises(ValueError, match="`minor_radius` must be < `major_radius`"):
        M.torus(0.5, 2.0)
    with pytest.raises(ValueError, match="`profile` must have a point with radius > 0"):
        M.revolve([[0.0, 0.0], [0.0, 1.0]], segments=3)
    with pytest.raises(ValueError, match="`profile` radii must be >= 0"):
        M.revolve([[0.0, 0.0], [-1.0, 1.0]], segments=3)


def test_mesh_colors_and_texture_must_be_in_0_1_eagerly_and_under_jit(maybe_jit):
    """The documented ranges: colours and texture values in [0, 1]."""
    from gfxlab import check_message

    vertices, faces = jnp.eye(3), jnp.array([[0, 1, 2]])
    uvs = {"uvs": jnp.zeros((3, 2)), "uv_faces": faces}
    good_colors, good_texture = jnp.full((3, 3), 0.5), jnp.ones((2, 2, 3))
    make = maybe_jit(
        lambda colors, texture: M.Mesh(vertices, faces, colors, texture=texture, **uvs)
    )
    mesh = make(good_colors, good_texture)
    np.testing.assert_array_equal(mesh.colors, good_colors)
    for bad in (1.5, -0.25):
        for colors, texture, name in (
            (good_colors.at[1, 2].set(bad), good_texture, "colors"),
            (good_colors, good_texture.at[0, 1, 0].set(bad), "texture"),
        ):
            with pytest.raises(Exception) as info:
                jax.block_until_ready(make(colors, texture))
            message = check_message(info.value) or ""
            assert message.startswith(f"`{name}` must be in [0, 1]"), message
    with pytest.raises(ValueError, match=r"^`colors` must be in \[0, 1\]"):
        M.icosphere(0).with_colors(jnp.array([0.2, 2.0, 0.3]))
    with pytest.raises(ValueError, match="`texture` must be in"):
        M.Mesh(vertices, faces, texture=jnp.full((2, 2, 3), jnp.nan), **uvs)
