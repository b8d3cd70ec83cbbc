"""Bad input found by a fresh user of the library (raster displays, `Mesh`, `Ellipse`,
`BSpline`/`NURBS` built under `jit`): each gets a clear error naming the argument."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gfxlab import brdf, curves, labs, mesh, raster
from gfxlab.fit import fit

VERTICES = jnp.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
POINTS = jnp.stack([jnp.linspace(0.0, 2.0, 9), jnp.sin(jnp.linspace(0.0, 3.0, 9))], axis=-1)
FACES = jnp.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


@pytest.mark.parametrize("warm", [False, True], ids=["first-call", "after-a-good-call"])
def test_raster_scan_refuses_levels_outside_0_1_naming_frame_buffer(warm):
    if warm:
        raster.raster_scan(jnp.full((2, 2), 0.5))
    with pytest.raises(ValueError, match=r"^`frame_buffer` must be in \[0, 1\]$"):
        raster.raster_scan(jnp.full((2, 2), 2.0))


def test_random_scan_refuses_intensity_outside_0_1():
    segments = jnp.zeros((1, 2, 2))
    with pytest.raises(ValueError, match=r"^`intensity` must be in \[0, 1\]$"):
        raster.random_scan(segments, intensity=jnp.array([3.0]))
    beam = raster.random_scan(segments, intensity=jnp.array([0.25]))
    assert float(beam.intensity.max()) == 0.25


def test_raster_scan_under_jit_names_frame_buffer():
    with pytest.raises(Exception, match="`frame_buffer` must be in"):
        jax.jit(raster.raster_scan)(jnp.full((2, 2), -1.0))


def test_mesh_triangles_checks_traced_faces():
    good = jax.jit(lambda f: mesh.Mesh(VERTICES, f).triangles())(FACES[:1])
    np.testing.assert_array_equal(good, np.asarray(VERTICES)[np.asarray(FACES[:1])])
    with pytest.raises(Exception, match="`faces` must index the 4 vertices"):
        jax.jit(lambda f: mesh.Mesh(VERTICES, f).triangles())(jnp.array([[0, 1, 4]]))


@pytest.mark.parametrize("field", ["normals", "uvs"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_mesh_refuses_non_finite_normals_and_uvs(field, bad):
    width = 3 if field == "normals" else 2
    index = "normal_faces" if field == "normals" else "uv_faces"
    with pytest.raises(ValueError, match=rf"`{field}` must be finite"):
        mesh.Mesh(VERTICES, FACES, **{field: jnp.full((4, width), bad), index: FACES})


def test_mesh_with_vertices_keeps_the_vertex_count():
    m = mesh.Mesh(VERTICES, FACES)
    assert m.with_vertices(VERTICES * 2).num_vertices == 4
    with pytest.raises(ValueError, match="`vertices` must have shape"):
        m.with_vertices(jnp.zeros((5, 3)))


@pytest.mark.parametrize("t", [np.nan, np.inf])
def test_ellipse_call_refuses_non_finite_t(t):
    ellipse = curves.Ellipse(jnp.zeros(2), jnp.ones(2))
    with pytest.raises(ValueError, match="`t` must be finite"):
        ellipse(jnp.array([0.0, t]))
    np.testing.assert_allclose(ellipse(jnp.array([0.0])), [[1.0, 0.0]], atol=1e-12)


@pytest.mark.parametrize("transform", ["jit", "vmap"])
@pytest.mark.parametrize(
    "build, knots, message",
    [
        (lambda k: curves.BSpline(jnp.ones((5, 2)), 3, k), 6, "9 entries, got 6"),
        (lambda k: curves.BSpline(jnp.ones((5, 2)), 3, k, fit_knots=True), 6, "9 entries"),
        (lambda k: curves.BSpline(jnp.ones((5, 2)), 3, k, closed=True), 4, "6 breakpoints"),
        (lambda k: curves.NURBS(jnp.ones((5, 2)), jnp.ones(5), 3, k), 7, "9 entries, got 7"),
    ],
    ids=["bspline", "fitted-knots", "closed", "nurbs"],
)
def test_curves_built_under_a_transformation_check_the_knot_count(transform, build, knots, message):
    if transform == "jit":
        run, arg = jax.jit(build), jnp.linspace(0.0, 1.0, knots)
    else:
        run, arg = jax.vmap(build), jnp.tile(jnp.linspace(0.0, 1.0, knots), (2, 1))
    with pytest.raises(ValueError, match=message):
        run(arg)


def test_mesh_transform_names_the_matrix():
    m = mesh.Mesh(VERTICES, FACES)
    np.testing.assert_allclose(m.transform(jnp.eye(4) * 2.0).vertices, VERTICES)  # w = 2 too
    with pytest.raises(ValueError, match="`matrix` must have shape"):
        m.transform(jnp.eye(3))


def test_mesh_refuses_an_empty_texture():
    faces = FACES[:2]
    with pytest.raises(ValueError, match="`texture` must hold at least one texel"):
        mesh.Mesh(
            VERTICES, faces, uvs=jnp.full((4, 2), 0.5), uv_faces=faces, texture=jnp.zeros((0, 4, 3))
        )


def test_phosphor_frames_decay_is_a_scalar():
    beam = raster.raster_scan(jnp.full((2, 2), 0.5))
    assert raster.phosphor_frames(beam, (2, 2), decay=0.5).shape[1:] == (2, 2)
    with pytest.raises(ValueError, match="`decay` must have shape"):
        raster.phosphor_frames(beam, (2, 2), decay=jnp.array([0.5, 0.5]))


@pytest.mark.parametrize(
    "call",
    [
        lambda v: raster.raster_scan(jnp.full((2, 2), 0.5), interlaced=v),
        lambda v: fit(lambda p: p**2, jnp.array(1.0), max_steps=1, progress=v),
        lambda v: brdf.Phong(ks=0.5, shininess=10.0, kd=0.3, normalized=v),
    ],
    ids=["interlaced", "progress", "normalized"],
)
def test_flags_take_true_or_false_only(call):
    """`bool("no")` is True: a string, a number or None for a flag is refused, naming it."""
    call(np.bool_(True))  # NumPy's bool is a bool
    for bad in ("no", 0, None):
        with pytest.raises(TypeError, match="must be True or False"):
            call(bad)


def test_interlaced_scan_differs_from_progressive():
    frame = jnp.linspace(0.0, 1.0, 12).reshape(4, 3)
    progressive = raster.raster_scan(frame, interlaced=False)
    interlaced = raster.raster_scan(frame, interlaced=True)
    assert not np.array_equal(np.asarray(progressive.positions), np.asarray(interlaced.positions))


@pytest.mark.parametrize(
    "call",
    [
        lambda v: curves.fit_bezier(POINTS, 2, full_output=v),
        lambda v: curves.fit_bezier(POINTS, 2, correct_parameters=v),
        lambda v: curves.fit_ellipse(POINTS, full_output=v),
        lambda v: labs.kernel_env(cache=v),
    ],
    ids=["bezier-full_output", "bezier-correct_parameters", "ellipse-full_output", "cache"],
)
def test_more_flags_take_true_or_false_only(call):
    for bad in ("no", 1, None):
        with pytest.raises(TypeError, match="must be True or False"):
            call(bad)


@pytest.mark.parametrize(
    ("timeout", "error"),
    [(True, TypeError), ("10", TypeError), (float("nan"), ValueError), (float("inf"), ValueError)],
)
def test_run_lab_timeout_is_a_positive_finite_number(timeout, error, tmp_path):
    with pytest.raises(error, match="`timeout`"):
        labs.run_lab(labs.find_lab("00"), tmp_path, timeout=timeout)
    assert not any(tmp_path.iterdir()), "refused before any kernel started"


def test_write_index_creates_its_folder(tmp_path):
    page = labs.write_index(tmp_path / "new" / "site", [])
    assert page.is_file() and page.parent == tmp_path / "new" / "site"


def test_apply_names_mismatched_batches_and_non_square_matrices():
    from gfxlab import transforms

    with pytest.raises(ValueError, match=r"batch shapes of `matrix` \(4,\) and `points` \(3,\)"):
        transforms.apply(jnp.ones((4, 3, 3)), jnp.ones((3, 5, 2)))
    with pytest.raises(ValueError, match="`matrix` must be a square homogeneous matrix"):
        transforms.apply(jnp.ones((3, 4)), jnp.ones((5, 2)))
    batched = transforms.apply(jnp.broadcast_to(jnp.eye(3), (4, 3, 3)), jnp.ones((1, 5, 2)))
    assert batched.shape == (4, 5, 2)


def test_lab_lookup_and_paths_are_clear_errors(tmp_path):
    with pytest.raises(TypeError, match="`name` must be a lab number"):
        labs.find_lab(None)
    assert labs.find_lab(3).name.startswith("03_") and labs.find_lab("03") == labs.find_lab(3)
    with pytest.raises(NotADirectoryError, match="`directory` must be an existing folder"):
        labs.list_labs(tmp_path / "missing")
    assert labs.list_labs(tmp_path) == []  # an existing folder without labs
    script = tmp_path / "lab.py"
    script.write_text("print(1)\n")
    with pytest.raises(ValueError, match=r"`path` must be a Jupyter notebook \(a \.ipynb file\)"):
        labs.run_lab(script, tmp_path)
    with pytest.raises(FileNotFoundError, match="`path`: no notebook at"):
        labs.run_lab(tmp_path / "missing.ipynb", tmp_path)
    with pytest.raises(ValueError, match="must be a Jupyter notebook"):  # before any kernel
        labs.run_all(tmp_path / "out", labs=[labs.find_lab(0), script])
    assert not (tmp_path / "out" / "00_welcome.html").exists()


def test_lab_error_without_html_says_nothing_of_it():
    error = labs.LabError("00_welcome.ipynb", None, "", "the kernel died", None)
    assert "partial HTML" not in str(error) and "None" not in str(error)
    assert "partial HTML" in str(labs.LabError("x.ipynb", 0, "1/0", "ZeroDivisionError", "x.html"))


def test_lab_runner_arguments_are_checked_before_anything_runs(tmp_path, monkeypatch):
    bad = tmp_path / "broken.ipynb"
    bad.write_text("{not json")
    for call in (lambda: labs.run_lab(bad, tmp_path), lambda: labs.lab_title(bad)):
        with pytest.raises(ValueError, match="is not a readable notebook"):
            call()
    with pytest.raises(TypeError, match="`log` must be a function"):
        labs.run_all(tmp_path / "out", labs=[labs.find_lab(0)], log=5)
    with pytest.raises(TypeError, match="`labs` must be a list of notebook paths"):
        labs.run_all(tmp_path / "out", labs="00_welcome.ipynb")
    with pytest.raises(TypeError, match="`labs` must hold notebook paths, got int"):
        labs.run_all(tmp_path / "out", labs=[labs.find_lab(0), 3])
    with pytest.raises(TypeError, match="`directory` must be a folder path"):
        labs.list_labs(5)
    assert not (tmp_path / "out").exists()
    assert labs.find_lab("TRANSFORMS") == labs.find_lab("transforms")
    with pytest.raises(LookupError, match="is not a notebook file and matches no lab"):
        labs.find_lab(tmp_path / "nope.ipynb")
    monkeypatch.setenv("GFXLAB_LABS", str(tmp_path / "missing"))
    with pytest.raises(NotADirectoryError, match=r"\$GFXLAB_LABS must be an existing folder"):
        labs.list_labs()


def test_decode_takes_a_uint8_array_of_the_file():
    from gfxlab import jpeg

    image = np.arange(16 * 16 * 3, dtype=np.uint8).reshape(16, 16, 3)
    data = jpeg.encode(image)
    np.testing.assert_array_equal(jpeg.decode(np.frombuffer(data, np.uint8)), jpeg.decode(data))
    with pytest.raises(TypeError, match="`data` as an array must be 1-D uint8.*int16"):
        jpeg.decode(np.frombuffer(data, np.uint8).astype(np.int16))
    # a concrete JAX array of the bytes is the same file; a traced one is refused by name
    np.testing.assert_array_equal(jpeg.decode(jnp.frombuffer(data, jnp.uint8)), jpeg.decode(data))
    np.testing.assert_array_equal(jpeg.decode(np.bytes_(data)), jpeg.decode(data))
    with pytest.raises(TypeError, match="`data` must be a concrete byte string.*traced"):
        jax.jit(jpeg.decode)(jnp.frombuffer(data, jnp.uint8))
    with pytest.raises(TypeError, match="`data` as an array must be 1-D uint8.*2-D"):
        jpeg.decode(np.frombuffer(data, np.uint8)[None])


def test_project_takes_a_4x4_matrix_and_3d_points():
    from gfxlab import viewing

    with pytest.raises(ValueError, match=r"`matrix` must be a 4x4 projection matrix"):
        viewing.project(jnp.eye(3), jnp.ones((2, 2)))  # a 2D homogeneous matrix
    with pytest.raises(ValueError, match=r"`points` must have shape \(\.\.\., 3\)"):
        viewing.project(jnp.eye(4), jnp.ones((2, 2)))
    m = viewing.perspective(1.0, 1.5, 0.1, 10.0) @ viewing.look_at(
        jnp.array([0.0, 0.0, 5.0]), jnp.zeros(3), jnp.array([0.0, 1.0, 0.0])
    )
    points = jnp.array([[0.1, 0.2, 0.3], [-1.0, 0.5, 2.0]])
    np.testing.assert_allclose(viewing.project(m, points), jax.jit(viewing.project)(m, points))
