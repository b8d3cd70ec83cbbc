"""Video export and container parsing (gfxlab.animation.video)."""

import imageio.v2 as iio
import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

from gfxlab import animation as A

# ffmpeg runs as a child process (fork + exec); JAX's fork warning does not apply.
pytestmark = pytest.mark.filterwarnings("ignore:os.fork:RuntimeWarning")

T, H, W = 9, 31, 44  # odd height: the 4:2:0 codecs pad it


@pytest.fixture(scope="module")
def frames():
    yy, xx = np.mgrid[:H, :W]
    # a dot moving right, different in every frame
    return np.stack(
        [
            ((xx - 4 * t - 4) ** 2 + (yy - 15) ** 2 < 30)[..., None] * np.array([1.0, 0.6, 0.2])
            for t in range(T)
        ]
    )


@pytest.mark.parametrize("fmt", sorted(A.FORMATS))
def test_written_video_opens_and_container_counts_frames(fmt, frames, tmp_path):
    path = A.save_animation(frames, tmp_path / f"clip.{fmt}", fps=10)
    info = A.container_info(path)
    assert info.frame_count == T
    assert info.file_size == (tmp_path / f"clip.{fmt}").stat().st_size
    if fmt == "gif":
        with Image.open(path) as im:
            assert im.n_frames == T and im.size == (W, H)
            assert im.info["duration"] == 100
        assert (info.width, info.height) == (W, H)
        np.testing.assert_allclose(info.duration, T / 10)
        return
    # decoded by ffmpeg (through imageio-ffmpeg): the same number of frames
    reader = imageio_ffmpeg.read_frames(path)
    meta = next(reader)
    decoded = [
        np.frombuffer(f, np.uint8).reshape(meta["size"][1], meta["size"][0], 3) for f in reader
    ]
    assert len(decoded) == T
    assert (info.width, info.height) == meta["size"] == (W, H + 1)
    np.testing.assert_allclose(info.duration, T / 10, atol=0.02)
    np.testing.assert_allclose(info.fps, 10, rtol=1e-3)
    # the moving dot is where it was drawn (lossy codecs: loose tolerance)
    assert abs(decoded[5][15, 4 * 5 + 4, 0] / 255 - 1.0) < 0.25
    assert decoded[5][15, 40, 0] < 64


def test_container_details_and_imageio(frames, tmp_path):
    mp4 = A.save_animation(frames, tmp_path / "a.mp4", fps=10)
    with iio.get_reader(mp4, format="FFMPEG") as reader:
        assert reader.count_frames() == T
    info = A.container_info(mp4)
    assert info.format == "MP4" and info.codec == "avc1"
    names = [n.name for n in info.tree]
    assert names[0] == "ftyp" and "moov" in names and "mdat" in names
    text = A.format_tree(info.tree)
    assert "stsz" in text and "sample_count=9" in text
    mov = A.container_info(A.save_animation(frames, tmp_path / "a.mov", fps=10))
    assert mov.format == "MOV" and mov.tree[0].fields["major_brand"].startswith("qt")
    avi = A.container_info(A.save_animation(frames, tmp_path / "a.avi", fps=10))
    assert avi.codec == "MJPG" and avi.tree[0].name == "RIFF:AVI "
    avih = next(n for n in _walk(avi.tree) if n.name == "avih")
    assert avih.fields["total_frames"] == T
    flv = A.container_info(A.save_animation(frames, tmp_path / "a.flv", fps=10))
    assert flv.codec.startswith("Sorenson") and flv.tree[1].name == "script:onMetaData"
    webm = A.container_info(A.save_animation(frames, tmp_path / "a.webm", fps=10))
    assert webm.format == "WebM" and webm.codec == "V_VP8"
    wmv = A.container_info(A.save_animation(frames, tmp_path / "a.wmv", fps=10))
    assert wmv.codec == "WMV2" and wmv.tree[0].name == "Header"
    # uint8 and greyscale frames are accepted too
    grey = (frames[..., 0] * 255).astype(np.uint8)
    assert A.container_info(A.save_animation(grey, tmp_path / "g.gif", fps=5)).frame_count == T


def test_video_bad_inputs(frames, tmp_path):
    with pytest.raises(ValueError, match="format"):
        A.save_animation(frames, tmp_path / "clip.xyz", fps=10)
    with pytest.raises(ValueError, match="format"):
        A.save_animation(frames, tmp_path / "clip", fps=10, format="mkv2")
    with pytest.raises(ValueError, match="fps"):
        A.save_animation(frames, tmp_path / "clip.mp4", fps=0)
    with pytest.raises(ValueError, match="frames"):
        A.save_animation(frames[0, :, :, 0], tmp_path / "clip.mp4", fps=10)
    with pytest.raises(ValueError, match="channels"):
        A.save_animation(np.zeros((2, 4, 4, 2)), tmp_path / "clip.mp4", fps=10)
    with pytest.raises(TypeError, match="uint8"):
        A.save_animation(np.zeros((2, 4, 4), np.int32), tmp_path / "clip.gif", fps=10)
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"not a video at all")
    with pytest.raises(ValueError, match="not a recognised video container"):
        A.container_info(junk)
    whole = open(A.save_animation(frames, tmp_path / "c.mp4", fps=10), "rb").read()
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole[:60])  # the ftyp box and a piece of the next: no moov
    with pytest.raises(ValueError, match="moov|damaged"):
        A.container_info(cut)


def _walk(nodes):
    """Every node of a container tree, depth first (public `Node.children` only)."""
    for node in nodes:
        yield node
        yield from _walk(node.children)
