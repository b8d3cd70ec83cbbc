"""gfxlab.image: bad inputs (eagerly and under jit), size limits, Pillow errors wrapped in
ImageFileError, constructors that validate, and eager == jit."""

import io
import logging

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from PIL import Image

from gfxlab import image as gi

IMG = np.random.default_rng(5).integers(0, 256, (9, 11), dtype=np.uint8)
RUNTIME = (ValueError, RuntimeError)  # a check firing inside jit (equinox.error_if)


# --------------------------------------------------------------------------- None


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.read_image(None), "path"),
        (lambda: gi.image_info(None), "path"),
        (lambda: gi.write_image(None, IMG), "path"),
        (lambda: gi.write_image("a.png", None), "image"),
        (lambda: gi.median_filter(None), "image"),
        (lambda: gi.median_filter(IMG, size=None), "size"),
        (lambda: gi.mean_filter(None), "image"),
        (lambda: gi.gaussian_filter(None, sigma=1.0), "image"),
        (lambda: gi.gaussian_filter(IMG, sigma=None), "sigma"),
        (lambda: gi.median_filter(IMG, mode="constant", cval=None), "cval"),
        (lambda: gi.median_filter(IMG, mode="constant", cval=True), "cval"),
        (lambda: gi.median_filter(IMG, mode="constant", cval=np.True_), "cval"),
        # a traced boolean is refused as the Python one is (it was accepted under jit)
        (lambda: jax.jit(lambda c: gi.median_filter(IMG, mode="constant", cval=c))(True), "cval"),
        (lambda: jax.jit(lambda c: gi.mean_filter(IMG, mode="constant", cval=c))(True), "cval"),
        (lambda: gi.median(None), "values"),
        (lambda: gi.median_of_sum(None, [1, 2]), "x"),
        (lambda: gi.selection_network(5, None), "ranks"),
        (lambda: gi.add_salt_and_pepper(IMG / 255, key=None), "key"),
        (lambda: gi.add_salt_and_pepper(None, key=jax.random.key(0)), "image"),
        (lambda: gi.value_noise(None), "x"),
        (lambda: gi.fractal_noise(None), "x"),
        (lambda: gi.Polygon(None), "vertices"),
        (lambda: gi.Polyline(None), "vertices"),
        (lambda: gi.Circle(None, 1.0), "center"),
        (lambda: gi.Circle(jnp.zeros(2), None), "radius"),
        (lambda: gi.Circle(jnp.zeros(2), "abc"), "radius"),
        (lambda: gi.Polygon(jnp.zeros((3, 2)), stroke_width="wide"), "stroke_width"),
        (lambda: gi.rasterize_shapes(None, (4, 4)), "shapes"),
    ],
)
def test_none_and_wrong_types_are_type_errors_naming_the_argument(call, name):
    with pytest.raises(TypeError, match=name):
        call()


# --------------------------------------------------------------------------- constructors


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.Circle(jnp.zeros(2), -1.0), "radius"),
        (lambda: gi.Circle(jnp.zeros(2), np.nan), "radius"),
        (lambda: gi.Circle(jnp.array([0.0, np.inf]), 1.0), "center"),
        (lambda: gi.Circle(jnp.zeros(3), 1.0), "center"),
        (lambda: gi.Circle(jnp.zeros(2), jnp.ones(2)), "radius"),
        (lambda: gi.Circle(jnp.zeros(2), 1.0, fill=(2, 0, 0)), "fill"),
        (lambda: gi.Polygon(jnp.array([[0.0, 0.0], [1.0, np.nan], [2.0, 0.0]])), "vertices"),
        (lambda: gi.Polygon(jnp.zeros((3, 2)), stroke=(0, 0, 7)), "stroke"),
        (lambda: gi.Polygon(jnp.zeros((3, 2)), stroke_width=-2), "stroke_width"),
        (lambda: gi.Polyline(jnp.zeros((3, 2)), stroke_width=np.inf), "stroke_width"),
        (lambda: gi.Polyline(jnp.zeros((3, 2)), stroke="red"), "stroke"),
    ],
)
def test_shapes_validate_at_construction(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_shapes_are_pytrees_that_work_under_jit():
    @jax.jit
    def render(radius):
        return gi.rasterize_shapes([gi.Circle(jnp.array([3.0, 3.0]), radius)], (7, 7))

    small, large = render(1.0), render(2.5)
    assert float(small.sum()) > float(large.sum())  # a larger black disc on white
    np.testing.assert_allclose(
        render(2.5), gi.rasterize_shapes([gi.Circle(jnp.array([3.0, 3.0]), 2.5)], (7, 7))
    )


def test_rasterized_polygon_fill_is_raster_supersampling_of_the_even_odd_test():
    from gfxlab import raster

    star = jnp.array([[5.0, 0.5], [7.0, 9.5], [0.5, 3.0], [9.5, 3.0], [3.0, 9.5]])  # self-crossing
    ours = gi.rasterize_shapes(
        [gi.Polygon(star, fill=(0, 0, 0))], (10, 10), samples=3, background=(1, 1, 1)
    )
    coverage = raster.supersample(lambda p: raster.inside_polygon(p, star), (10, 10), samples=3)
    np.testing.assert_allclose(1.0 - ours[..., 0], coverage, atol=1e-12)


# --------------------------------------------------------------------------- sizes, NaN


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.median_filter(IMG, size=10**6), "size"),
        (lambda: gi.median_filter(IMG, size=(40, 40)), "size"),
        (lambda: gi.median_filter(IMG, footprint=np.ones((40, 40), bool)), "footprint"),
        (lambda: gi.mean_filter(IMG, size=10**6), "size"),
        (lambda: gi.gaussian_filter(IMG, sigma=1e6), "sigma"),
        (lambda: gi.gaussian_filter(IMG, sigma=1.0, radius=10**6), "radius"),
        (lambda: gi.gaussian_filter(IMG, sigma=1.0, truncate=1e9), "truncate"),
        (lambda: gi.median(np.zeros(10**5)), "values"),
        (lambda: gi.selection_network(10**6, [3]), "n"),
        (lambda: gi.cross_footprint(10**6), "radius"),
        (lambda: gi.synthetic_scene((10**6, 10)), "shape"),
        (lambda: gi.rasterize_shapes([], (4, 4), samples=10**4), "samples"),
        (lambda: gi.rasterize_shapes([], (10**7, 4)), "shape"),
        (lambda: gi.fractal_noise(jnp.zeros((2, 2)), octaves=10**9), "octaves"),
    ],
)
def test_huge_sizes_are_refused_before_allocating(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.gaussian_filter(IMG, sigma=np.inf), "sigma"),
        (lambda: gi.gaussian_filter(IMG, sigma=np.nan), "sigma"),
        (lambda: gi.gaussian_filter(IMG, sigma=(1.0, -1.0)), "sigma"),
        (lambda: gi.gaussian_filter(IMG, sigma=0.0), "sigma"),
        (lambda: gi.gaussian_filter(IMG, sigma=1.0, truncate=np.nan), "truncate"),
        (lambda: gi.gaussian_filter(IMG, sigma=1.0, truncate=-1.0), "truncate"),
        (lambda: gi.median_filter(IMG, mode="constant", cval=np.nan), "cval"),
        (lambda: gi.mean_filter(IMG, mode="constant", cval=np.inf), "cval"),
        (lambda: gi.median_filter(IMG, mode=None), "mode"),
        (lambda: gi.add_salt_and_pepper(IMG / 255, amount=np.nan, key=jax.random.key(0)), "amount"),
        (lambda: gi.add_salt_and_pepper(IMG / 255, amount=1.5, key=jax.random.key(0)), "amount"),
        (lambda: gi.value_noise(jnp.array([[0.0, np.nan]])), "x"),
        (lambda: gi.gradient_noise(jnp.array([[np.inf]])), "x"),
        (lambda: gi.fractal_noise(jnp.zeros((2, 1)), lacunarity=np.nan), "lacunarity"),
        (lambda: gi.fractal_noise(jnp.zeros((2, 1)), gain=0.0), "gain"),
        (lambda: gi.median_filter(np.zeros((0, 4))), "image"),
    ],
)
def test_nan_inf_and_out_of_range_parameters_are_value_errors(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_traced_parameters_are_checked_under_jit():
    image = jnp.asarray(IMG / 255.0)
    cases = [
        (lambda s: gi.gaussian_filter(image, sigma=s, radius=2), jnp.asarray(-1.0), "sigma"),
        (lambda s: gi.gaussian_filter(image, sigma=s, radius=2), jnp.asarray(np.inf), "sigma"),
        (lambda c: gi.median_filter(image, mode="constant", cval=c), jnp.asarray(np.nan), "cval"),
        (
            lambda a: gi.add_salt_and_pepper(image, amount=a, key=jax.random.key(1)),
            jnp.asarray(2.0),
            "amount",
        ),
        (lambda x: gi.value_noise(x), jnp.array([[np.nan, 0.0]]), "x"),
        (lambda g: gi.fractal_noise(jnp.zeros((3, 1)), gain=g), jnp.asarray(-0.5), "gain"),
    ]
    for fn, bad, name in cases:
        with pytest.raises(RUNTIME, match=name):
            jax.block_until_ready(jax.jit(fn)(bad))


def test_gaussian_sigma_inf_is_not_an_overflow_error():
    with pytest.raises(ValueError, match="sigma.*finite"):
        gi.gaussian_filter(IMG, sigma=float("inf"))


# --------------------------------------------------------------------------- files


def _png_bytes():
    buffer = io.BytesIO()
    Image.fromarray(IMG).save(buffer, format="PNG")
    return buffer.getvalue()


def test_read_image_wraps_pillow_errors_naming_the_file(tmp_path):
    not_image = tmp_path / "notes.png"
    not_image.write_bytes(b"this is not an image at all")
    truncated = tmp_path / "truncated.png"
    truncated.write_bytes(_png_bytes()[:60])
    for path in (not_image, truncated):
        for fn in (gi.read_image, gi.image_info):
            if fn is gi.image_info and path is truncated:
                continue  # the header is intact: image_info reads only the header
            with pytest.raises(gi.ImageFileError, match=path.name) as info:
                fn(path)
            assert isinstance(info.value, ValueError) and info.value.__cause__ is not None
    with pytest.raises(FileNotFoundError):
        gi.read_image(tmp_path / "missing.png")


def test_read_image_decompression_bomb_is_an_image_file_error(tmp_path, monkeypatch):
    path = gi.write_image(tmp_path / "big.png", np.zeros((64, 64), np.uint8))
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 100)  # 64 x 64 > 2 x 100: a "bomb"
    with pytest.raises(gi.ImageFileError, match="big.png.*decompression-bomb"):
        gi.read_image(path)


def test_read_image_corrupt_tiff_is_an_image_file_error(tmp_path):
    path = gi.write_image(tmp_path / "scan.tif", IMG)
    data = bytearray(path.read_bytes())
    offset = int.from_bytes(data[4:8], "little")  # first IFD
    count = int.from_bytes(data[offset : offset + 2], "little")
    for k in range(count):  # make every tag's type invalid (Pillow: TypeError/KeyError/...)
        entry = offset + 2 + 12 * k
        data[entry + 2 : entry + 4] = (0xFFFF).to_bytes(2, "little")
    path.write_bytes(bytes(data))
    with pytest.raises(gi.ImageFileError, match="scan.tif"):
        gi.read_image(path)


# --------------------------------------------------------------------------- eager == jit


def test_eager_equals_jit():
    grey = jnp.asarray(IMG)
    colour = jnp.asarray(np.random.default_rng(2).random((8, 7, 3)))
    cases = [
        (lambda x: gi.median_filter(x, size=3), grey),
        (lambda x: gi.median_filter(x, size=(2, 3), mode="constant", cval=7), grey),
        (lambda x: gi.median_filter(x, footprint=gi.cross_footprint(), mode="wrap"), colour),
        (lambda x: gi.mean_filter(x, size=4, mode="mirror"), colour),
        (lambda x: gi.gaussian_filter(x, sigma=(1.0, 0.7), mode="nearest"), grey),
        (lambda x: gi.median(x, axis=0), colour),
        (lambda x: gi.median_of_sum(x[0, :, 0], x[1, :, 0])[0], colour),
        (lambda x: gi.add_salt_and_pepper(x, amount=0.3, key=jax.random.key(3)), colour),
        (lambda x: gi.value_noise(x[..., :2] * 5, key=jax.random.key(2)), colour),
        (lambda x: gi.gradient_noise(x[..., :1] * 5, key=jax.random.key(2)), colour),
        (lambda x: gi.fractal_noise(x[..., :2] * 3, octaves=3, kind="value"), colour),
    ]
    for fn, arg in cases:
        eager, jitted = np.asarray(fn(arg)), np.asarray(jax.jit(fn)(arg))
        assert eager.dtype == jitted.dtype and eager.shape == jitted.shape
        np.testing.assert_allclose(eager, jitted, rtol=1e-13, atol=1e-15)


def test_median_filter_compiles_once_per_shape_and_window(caplog):
    gi.median_filter(IMG, size=3, mode="constant", cval=1.0)
    with jax.log_compiles(), caplog.at_level(logging.DEBUG):
        gi.median_filter(IMG, size=3, mode="constant", cval=9.0)  # cval is traced
        gi.median_filter(IMG + 1, size=3, mode="constant", cval=2)
        compiles = [r for r in caplog.records if "Compiling" in r.getMessage()]
        gi.median_filter(IMG, size=5, mode="constant", cval=2)  # a new window compiles
        assert [r for r in caplog.records if "Compiling" in r.getMessage()] != []
    assert compiles == []


# ------------------------------------------------------------------ NaN data (issue 17)

NAN_IMAGE = np.where(IMG > 200, np.nan, IMG / 255.0)


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.median_filter(NAN_IMAGE), "image"),
        (lambda: gi.mean_filter(NAN_IMAGE), "image"),
        (lambda: gi.gaussian_filter(NAN_IMAGE, sigma=1.0), "image"),
        (lambda: gi.add_salt_and_pepper(NAN_IMAGE, key=jax.random.key(0)), "image"),
        (lambda: gi.median(jnp.array([1.0, np.nan, 2.0])), "values"),
        (lambda: gi.median_of_sum(jnp.array([1.0, np.inf]), jnp.zeros(2)), "x"),
        (lambda: gi.write_svg("picture.png", [], (4, 4)), "path"),
    ],
)
def test_nan_data_and_wrong_file_kinds_are_value_errors(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda: gi.Polyline(jnp.zeros((3, 2)), stroke=None), "stroke"),
        (lambda: gi.rasterize_shapes([], (4, 4), background=None), "background"),
    ],
)
def test_required_colours_are_type_errors(call, name):
    with pytest.raises(TypeError, match=name):
        call()


def test_nan_data_and_ignored_cval_are_checked_under_jit():
    image = jnp.asarray(IMG / 255.0)
    cases = [
        (lambda x: gi.median_filter(x), jnp.asarray(NAN_IMAGE), "image"),
        (lambda x: gi.gaussian_filter(x, sigma=1.0), jnp.asarray(NAN_IMAGE), "image"),
        (lambda c: gi.median_filter(image, cval=c), jnp.asarray(np.nan), "cval"),  # reflect
        (lambda c: gi.mean_filter(image, cval=c), jnp.asarray(np.inf), "cval"),
        (lambda v: gi.median(v), jnp.array([1.0, np.nan, 2.0]), "values"),
        (
            lambda v: gi.Polygon(v).vertices,
            jnp.array([[0.0, 0.0], [1, np.nan], [2, 0]]),
            "vertices",
        ),
        (lambda r: gi.Circle(jnp.zeros(2), r).radius, jnp.asarray(-1.0), "radius"),
    ]
    for fn, bad, name in cases:
        with pytest.raises(RUNTIME, match=name):
            jax.block_until_ready(jax.jit(fn)(bad))
