"""gfxlab.image files, formats and vector shapes, against Pillow, raw headers and shapely."""

import pathlib
import struct
import xml.etree.ElementTree as ET

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import shapely.geometry
from PIL import Image

from gfxlab import image as gi
from gfxlab.raster import pixel_to_index

RNG = np.random.default_rng(7)
DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "images"


def rgb_image(shape=(21, 34, 3)):
    return RNG.integers(0, 256, shape, dtype=np.uint8)


def few_colours(shape=(16, 24), colours=12):
    palette = RNG.integers(0, 256, (colours, 3), dtype=np.uint8)
    return palette[RNG.integers(0, colours, shape)]


# --------------------------------------------------------------------------- round trips


@pytest.mark.parametrize(
    ("suffix", "options"),
    [
        (".png", {}),
        (".bmp", {}),
        (".tif", {}),
        (".tif", {"compression": "tiff_lzw"}),
        (".tiff", {"compression": "tiff_adobe_deflate"}),
        (".png", {"compress_level": 9}),
    ],
)
@pytest.mark.parametrize("channels", [0, 1, 3, 4])
def test_lossless_round_trip_is_exact(tmp_path, suffix, options, channels):
    if channels == 4 and suffix == ".bmp":
        pytest.raises(ValueError, gi.write_image, tmp_path / "a.bmp", rgb_image((5, 6, 4)))
        return
    shape = (13, 17) if channels == 0 else (13, 17, channels)
    image = rgb_image(shape)
    path = gi.write_image(tmp_path / f"image{suffix}", image, **options)
    back = gi.read_image(path, as_float=False)
    expected = image[..., 0] if channels == 1 else image
    assert back.dtype == np.uint8
    np.testing.assert_array_equal(back, expected)
    np.testing.assert_array_equal(gi.read_image(path), expected / 255.0)  # exactly rounded


def test_grey_alpha_png_round_trip(tmp_path):
    image = rgb_image((9, 8, 2))
    back = gi.read_image(gi.write_image(tmp_path / "la.png", image), as_float=False)
    np.testing.assert_array_equal(back, image)


def test_gif_is_exact_for_at_most_256_colours(tmp_path):
    image = few_colours()
    back = gi.read_image(gi.write_image(tmp_path / "few.gif", image), as_float=False)
    np.testing.assert_array_equal(back, image)


def test_gif_transparency(tmp_path):
    image = np.concatenate([few_colours((8, 9)), np.full((8, 9, 1), 255, np.uint8)], axis=-1)
    image[2:4, 3:6, 3] = 0
    path = gi.write_image(tmp_path / "alpha.gif", image)
    back = gi.read_image(path, as_float=False)
    np.testing.assert_array_equal(back[..., 3] == 0, image[..., 3] == 0)
    opaque = image[..., 3] == 255
    np.testing.assert_array_equal(back[..., :3][opaque], image[..., :3][opaque])
    assert gi.image_info(path)["transparency"]


def test_animation_round_trip(tmp_path):
    frames = [few_colours((10, 12), colours=8) for _ in range(4)]
    for suffix in (".gif", ".png", ".tif"):
        path = gi.write_image(tmp_path / f"anim{suffix}", frames, duration=80)
        info = gi.image_info(path)
        assert info["frames"] == 4 and info["animated"]
        for i, frame in enumerate(frames):
            np.testing.assert_array_equal(gi.read_image(path, frame=i, as_float=False), frame)


def test_float_images_are_rounded_and_clipped(tmp_path):
    image = RNG.uniform(-0.2, 1.2, (7, 9, 3))
    back = gi.read_image(gi.write_image(tmp_path / "f.png", jnp.asarray(image)), as_float=False)
    np.testing.assert_array_equal(back, np.round(np.clip(image, 0, 1) * 255).astype(np.uint8))
    flags = RNG.random((4, 5)) < 0.5
    back = gi.read_image(gi.write_image(tmp_path / "b.png", flags), as_float=False)
    np.testing.assert_array_equal(back, flags * 255)


def test_jpeg_matches_pillow_and_is_close(tmp_path):
    image = (gi.synthetic_scene((48, 64)) * 255).round().astype(np.uint8)
    path = gi.write_image(tmp_path / "q95.jpg", image, quality=95)
    back = gi.read_image(path, as_float=False)
    np.testing.assert_array_equal(back, np.asarray(Image.open(path).convert("RGB")))
    mse = np.mean((back.astype(float) - image) ** 2)
    assert 10 * np.log10(255**2 / mse) > 29  # PSNR in dB (a tiny, noisy picture)
    # Pillow writes the same bytes for the same options.
    reference = tmp_path / "pillow.jpg"
    Image.fromarray(image).save(reference, quality=95)
    assert path.read_bytes() == reference.read_bytes()


def test_sixteen_bit_png(tmp_path):
    values = RNG.integers(0, 65536, (5, 6)).astype(np.uint16)
    Image.fromarray(values).save(tmp_path / "deep.png")
    np.testing.assert_array_equal(gi.read_image(tmp_path / "deep.png", as_float=False), values)
    np.testing.assert_allclose(gi.read_image(tmp_path / "deep.png"), values / 65535.0)
    assert gi.image_info(tmp_path / "deep.png")["bit_depth"] == 16


def test_palette_and_bilevel_files_expand(tmp_path):
    image = few_colours((6, 7), colours=5)
    Image.fromarray(image).convert("P", palette=Image.Palette.ADAPTIVE).save(tmp_path / "p.png")
    np.testing.assert_array_equal(gi.read_image(tmp_path / "p.png", as_float=False), image)
    bits = RNG.random((6, 7)) < 0.5
    Image.fromarray(bits).save(tmp_path / "bits.bmp")
    np.testing.assert_array_equal(gi.read_image(tmp_path / "bits.bmp", as_float=False), bits * 255)
    assert gi.image_info(tmp_path / "bits.bmp")["bits_per_pixel"] == 1


# --------------------------------------------------------------------------- image_info


def png_ihdr(path):
    data = pathlib.Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    width, height, depth, colour_type = struct.unpack(">IIBB", data[16:26])
    return width, height, depth, colour_type


def test_image_info_against_headers(tmp_path):
    image = rgb_image((20, 30, 3))
    png = gi.write_image(tmp_path / "a.png", image, dpi=(72, 72))
    info = gi.image_info(png)
    assert png_ihdr(png) == (30, 20, info["bit_depth"], 2)  # colour type 2 = truecolour
    assert (info["width"], info["height"], info["channels"], info["bits_per_pixel"]) == (
        30,
        20,
        3,
        24,
    )
    assert info["file_size"] == png.stat().st_size
    assert info["lossless"] and not info["transparency"] and not info["animated"]
    assert info["compression"] == "deflate"
    assert info["metadata"]["dpi"] == pytest.approx((72, 72), abs=0.01)
    assert info["compression_ratio"] == pytest.approx(20 * 30 * 3 / png.stat().st_size)

    rgba = gi.write_image(tmp_path / "b.png", rgb_image((4, 5, 4)))
    assert png_ihdr(rgba)[3] == 6 and gi.image_info(rgba)["transparency"]

    bmp = gi.write_image(tmp_path / "c.bmp", image)
    raw = bmp.read_bytes()
    bmp_width, bmp_height, _, bits = struct.unpack("<iiHH", raw[18:30])
    info = gi.image_info(bmp)
    assert raw[:2] == b"BM" and (bmp_width, abs(bmp_height)) == (30, 20)
    assert info["bits_per_pixel"] == bits == 24 and info["compression"] == "raw"

    gif = gi.write_image(tmp_path / "d.gif", few_colours())
    raw = gif.read_bytes()
    info = gi.image_info(gif)
    assert raw[:6] in (b"GIF87a", b"GIF89a") and info["compression"] == "LZW"
    assert (info["width"], info["height"]) == struct.unpack("<HH", raw[6:10])
    assert info["mode"] == "P" and 12 <= info["palette_colors"] <= 256
    assert info["bits_per_pixel"] == 8 and info["lossless"]

    jpg = gi.write_image(tmp_path / "e.jpg", image, quality=80)
    info = gi.image_info(jpg)
    assert jpg.read_bytes()[:2] == b"\xff\xd8"
    assert not info["lossless"] and info["compression"] == "DCT baseline"
    assert (
        gi.image_info(gi.write_image(tmp_path / "p.jpg", image, progressive=True))["compression"]
        == "DCT progressive"
    )

    tif = gi.write_image(tmp_path / "f.tif", image, compression="tiff_lzw")
    raw = tif.read_bytes()
    assert raw[:4] in (b"II*\x00", b"MM\x00*")
    assert gi.image_info(tif)["compression"] == "tiff_lzw" and gi.image_info(tif)["lossless"]


def test_image_info_matches_pillow(tmp_path):
    for suffix in (".png", ".jpg", ".bmp", ".tif", ".gif"):
        path = gi.write_image(tmp_path / f"x{suffix}", rgb_image((11, 12, 3)))
        info = gi.image_info(path)
        with Image.open(path) as im:
            assert info["format"] == im.format
            assert (info["width"], info["height"]) == im.size
            assert info["mode"] == im.mode
            assert info["frames"] == getattr(im, "n_frames", 1)


# --------------------------------------------------------------------------- data files


def test_shipped_scene_is_the_synthetic_scene():
    stored = gi.read_image(DATA / "scene.png", as_float=False)
    rendered = np.round(gi.synthetic_scene((256, 256)) * 255)
    assert stored.shape == (256, 256, 3)
    assert np.max(np.abs(stored - rendered)) <= 1
    assert sum(p.stat().st_size for p in DATA.iterdir()) < 300_000


def test_synthetic_scene_is_deterministic():
    a, b = (
        gi.synthetic_scene((30, 40), key=jax.random.key(3)),
        gi.synthetic_scene((30, 40), key=jax.random.key(3)),
    )
    np.testing.assert_array_equal(a, b)
    assert a.shape == (30, 40, 3) and 0 <= a.min() and a.max() <= 1
    assert not np.array_equal(a, gi.synthetic_scene((30, 40), key=jax.random.key(4)))
    with pytest.raises(ValueError, match="shape"):
        gi.synthetic_scene((0, 4))


# --------------------------------------------------------------------------- bad input


def test_file_bad_input(tmp_path):
    image = rgb_image((4, 5, 3))
    with pytest.raises(ValueError, match="format"):
        gi.write_image(tmp_path / "a.webp", image)
    with pytest.raises(ValueError, match="format"):
        gi.write_image(tmp_path / "a.png", image, format="WEBP")
    with pytest.raises(ValueError, match="alpha"):
        gi.write_image(tmp_path / "a.jpg", rgb_image((4, 5, 4)))
    with pytest.raises(ValueError, match="shape"):
        gi.write_image(tmp_path / "a.png", rgb_image((2, 4, 5, 3)))
    with pytest.raises(ValueError, match="shape"):
        gi.write_image(tmp_path / "a.png", rgb_image((4, 5, 6)))
    with pytest.raises(ValueError, match="one shape"):
        gi.write_image(tmp_path / "a.gif", [image, rgb_image((5, 5, 3))])
    with pytest.raises(ValueError, match="empty"):
        gi.write_image(tmp_path / "a.gif", [])
    with pytest.raises(ValueError, match="animation"):
        gi.write_image(tmp_path / "a.bmp", [image, image])
    with pytest.raises(ValueError, match="0..255"):
        gi.write_image(tmp_path / "a.png", np.full((3, 3), 300))
    with pytest.raises(ValueError, match="NaN"):
        gi.write_image(tmp_path / "a.png", np.full((3, 3), np.nan))
    with pytest.raises(TypeError, match="dtype"):
        gi.write_image(tmp_path / "a.png", np.full((3, 3), 1 + 1j))
    path = gi.write_image(tmp_path / "ok.png", image)
    with pytest.raises(ValueError, match="frame"):
        gi.read_image(path, frame=1)
    with pytest.raises(FileNotFoundError):
        gi.image_info(tmp_path / "missing.png")


# --------------------------------------------------------------------------- vector


def test_write_svg_maps_pixel_coordinates(tmp_path):
    shapes = [
        gi.Polygon(
            jnp.array([[1.0, 1.0], [8.0, 2.0], [4.0, 7.0]]), fill=(1, 0, 0), stroke=(0, 0, 0)
        ),
        gi.Polyline(jnp.array([[0.0, 9.0], [9.0, 0.0]]), stroke=(0, 0, 1), stroke_width=1.5),
        gi.Circle(jnp.array([6.0, 6.0]), 2.5, fill=(0, 1, 0)),
    ]
    path = gi.write_svg(tmp_path / "s.svg", shapes, (10, 12))
    root = ET.parse(path).getroot()
    ns = {"svg": "http://www.w3.org/2000/svg"}
    assert root.get("width") == "12" and root.get("height") == "10"
    polygon = root.find("svg:polygon", ns)
    points = [tuple(map(float, p.split(","))) for p in polygon.get("points").split()]
    # (x, y) y up -> SVG (x + 1/2, H - 1/2 - y) y down
    assert points == [(1.5, 8.5), (8.5, 7.5), (4.5, 2.5)]
    assert polygon.get("fill") == "#ff0000" and polygon.get("fill-rule") == "evenodd"
    assert root.find("svg:polyline", ns).get("stroke-width") == "1.5"
    circle = root.find("svg:circle", ns)
    assert (circle.get("cx"), circle.get("cy"), circle.get("r")) == ("6.5", "3.5", "2.5")


def pixel_squares(shape):
    height, width = shape
    return [
        [shapely.geometry.box(x - 0.5, y - 0.5, x + 0.5, y + 0.5) for x in range(width)]
        for y in range(height - 1, -1, -1)
    ]


def test_rasterize_shapes_coverage_matches_shapely():
    shape = (12, 14)
    points = np.array([[1.3, 0.7], [12.2, 3.1], [9.4, 10.6], [2.1, 8.2]])
    polygon = shapely.geometry.Polygon(points)
    circle = shapely.geometry.Point(7.2, 5.1).buffer(3.3, 256)
    for shape_obj, geom in [
        (gi.Polygon(jnp.asarray(points), fill=(0, 0, 0)), polygon),
        (gi.Circle(jnp.array([7.2, 5.1]), 3.3, fill=(0, 0, 0)), circle),
    ]:
        ours = 1.0 - gi.rasterize_shapes([shape_obj], shape, samples=8)[..., 0]
        exact = np.array(
            [[geom.intersection(sq).area for sq in row] for row in pixel_squares(shape)]
        )
        assert np.max(np.abs(ours - exact)) < 0.13
        assert np.mean(np.abs(ours - exact)) < 0.02


def test_rasterize_shapes_uses_the_pixel_convention():
    # A tiny square around pixel (x, y) = (3, 5) lights exactly that pixel.
    square = jnp.array([[2.6, 4.6], [3.4, 4.6], [3.4, 5.4], [2.6, 5.4]])
    image = gi.rasterize_shapes([gi.Polygon(square, fill=(1, 1, 1))], (8, 6), background=(0, 0, 0))
    row, col = np.asarray(pixel_to_index(jnp.array([3, 5]), (8, 6)))
    assert image[row, col, 0] > 0.5
    assert float(image.sum()) == pytest.approx(float(image[row, col].sum()))
    # Strokes: a horizontal line of width 1 through pixel centres y = 2 covers that row.
    line = gi.Polyline(jnp.array([[0.0, 2.0], [5.0, 2.0]]), stroke=(1, 1, 1), stroke_width=1.0)
    image = gi.rasterize_shapes([line], (8, 6), background=(0, 0, 0), samples=4)
    np.testing.assert_allclose(image[8 - 1 - 2, 1:5, 0], 1.0)


def test_vector_bad_input(tmp_path):
    with pytest.raises(ValueError, match="vertices"):
        gi.Polygon(jnp.zeros((3, 3)))
    with pytest.raises(TypeError, match="shapes"):
        gi.write_svg(tmp_path / "a.svg", [np.zeros((3, 2))], (4, 4))
    with pytest.raises(ValueError, match="colour"):
        gi.rasterize_shapes([gi.Polygon(jnp.zeros((3, 2)), fill=(2, 0, 0))], (4, 4))
    with pytest.raises(ValueError, match="shape"):
        gi.rasterize_shapes([], (0, 4))
    with pytest.raises(ValueError, match="samples"):
        gi.rasterize_shapes([], (4, 4), samples=0)
