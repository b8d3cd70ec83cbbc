"""Video files: write an animation, and read a container's structure ourselves.

`save_animation` encodes frames with the ffmpeg binary bundled by `imageio-ffmpeg`
(MP4/MOV with H.264, AVI with Motion-JPEG, FLV with Sorenson H.263, WebM with VP8, WMV
with Windows Media Video 8 in ASF) or with Pillow (animated GIF).

`container_info` parses the container format directly, without ffmpeg: RIFF chunks
(AVI), ISO base media boxes (MP4, MOV), FLV tags, EBML elements (WebM), ASF objects
(WMV) and GIF blocks. It reports the codec, frame count, duration, frame size and the
tree of boxes/chunks, which is what distinguishes the formats: the container is the
box that holds the compressed streams, the codec is how each frame is compressed.
"""

from __future__ import annotations

import dataclasses
import os
import struct
import warnings

import numpy as np

__all__ = ["FORMATS", "save_animation", "container_info", "ContainerInfo", "Node", "format_tree"]

#: Formats `save_animation` writes: suffix -> (ffmpeg muxer, codec, pixel format, label).
FORMATS = {
    "mp4": ("mp4", "libx264", "yuv420p", "H.264 in MPEG-4 Part 14"),
    "mov": ("mov", "libx264", "yuv420p", "H.264 in QuickTime"),
    "avi": ("avi", "mjpeg", "yuvj420p", "Motion JPEG in RIFF/AVI"),
    "flv": ("flv", "flv", "yuv420p", "Sorenson H.263 in Flash Video"),
    "webm": ("webm", "libvpx", "yuv420p", "VP8 in WebM (Matroska)"),
    "wmv": ("asf", "wmv2", "yuv420p", "Windows Media Video 8 in ASF"),
    "gif": (None, "gif", None, "LZW palette images in GIF89a (Pillow)"),
}


def _to_uint8_frames(frames) -> np.ndarray:
    arr = np.asarray(frames)
    if arr.ndim not in (3, 4) or arr.shape[0] < 1:
        raise ValueError(
            f"`frames` must be (T, H, W) or (T, H, W, C) with C in 1, 3, 4 and T >= 1, got "
            f"shape {arr.shape}"
        )
    if arr.ndim == 3:
        arr = arr[..., None]
    if arr.shape[-1] not in (1, 3, 4):
        raise ValueError(f"`frames` must have 1, 3 or 4 channels, got shape {arr.shape}")
    if arr.dtype != np.uint8:
        if not np.issubdtype(arr.dtype, np.floating):
            raise TypeError(f"`frames` must be uint8 or floats in [0, 1], got dtype {arr.dtype}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("`frames` contains NaN or inf")
        arr = np.round(np.clip(arr, 0.0, 1.0) * 255).astype(np.uint8)
    if arr.shape[-1] == 1:
        arr = np.repeat(arr, 3, axis=-1)
    return np.ascontiguousarray(arr[..., :3])


def save_animation(frames, path, *, fps: float = 24, format: str | None = None,
                   quality: int | None = None) -> str:
    """Write frames as a video (or animated GIF).

    **Arguments:**

    - `frames`: `(T, H, W)` or `(T, H, W, C)`, uint8 or floats in `[0, 1]` (alpha is
      dropped). Codecs with 4:2:0 chroma need even sizes: odd sizes are padded by
      repeating the last row/column.
    - `path`: the output file.
    - `fps`: frames per second (> 0). GIF stores delays in 1/100 s, so its rate is
      rounded to that.
    - `format`: one of `FORMATS` (`"mp4"`, `"mov"`, `"avi"`, `"flv"`, `"webm"`, `"wmv"`,
      `"gif"`); default from the file suffix.
    - `quality`: codec quality 1..10 (ffmpeg formats), default the codec's own.

    **Returns:** the path written, as a string.
    """
    path = os.fspath(path)
    if format is None:
        format = os.path.splitext(path)[1].lower().lstrip(".")
    format = str(format).lower()
    if format not in FORMATS:
        raise ValueError(f"`format` must be one of {sorted(FORMATS)} (or a path with such a "
                         f"suffix), got {format!r}")
    if not (isinstance(fps, int | float) and fps > 0):
        raise ValueError(f"`fps` must be a positive number, got {fps!r}")
    frames = _to_uint8_frames(frames)
    if format == "gif":
        _save_gif(frames, path, fps)
        return path
    muxer, codec, pix_fmt, _ = FORMATS[format]
    if pix_fmt.endswith("420p"):
        pad_h, pad_w = frames.shape[1] % 2, frames.shape[2] % 2
        frames = np.pad(frames, ((0, 0), (0, pad_h), (0, pad_w), (0, 0)), mode="edge")
    import imageio_ffmpeg

    params = ["-f", muxer]
    if codec == "libvpx":
        params += ["-deadline", "realtime", "-b:v", "1M"]
    with warnings.catch_warnings():
        # JAX warns on every fork; ffmpeg runs as a separate process (fork + exec), which
        # is safe.
        warnings.filterwarnings("ignore", message=r"os\.fork\(\) was called")
        _encode(imageio_ffmpeg, frames, path, fps, codec, pix_fmt, quality, params)
    return path


def _encode(imageio_ffmpeg, frames, path, fps, codec, pix_fmt, quality, params):
    _, h, w, _ = frames.shape
    writer = imageio_ffmpeg.write_frames(
        path, (w, h), fps=fps, codec=codec, pix_fmt_out=pix_fmt, quality=quality,
        macro_block_size=1, output_params=params, ffmpeg_log_level="error",
    )
    writer.send(None)
    try:
        for frame in frames:
            writer.send(frame.tobytes())
    finally:
        writer.close()


def _save_gif(frames: np.ndarray, path: str, fps: float) -> None:
    from PIL import Image

    delay_ms = max(10, int(round(100.0 / fps)) * 10)
    images = [Image.fromarray(f) for f in frames]
    # optimize=False and disposal=1 keep one image block per frame, even if two frames
    # happen to be equal.
    images[0].save(path, format="GIF", save_all=True, append_images=images[1:],
                   duration=delay_ms, loop=0, optimize=False, disposal=1)


# ------------------------------------------------------------ container parsing


@dataclasses.dataclass
class Node:
    """One box / chunk / tag / element of a container: its `name`, byte `offset` and
    `size` (including its header), `children`, and decoded `fields`."""

    name: str
    offset: int
    size: int
    children: list[Node] = dataclasses.field(default_factory=list)
    fields: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass
class ContainerInfo:
    """What `container_info` found.

    **Fields:** `format` (e.g. `"MP4"`), `codec` (the video codec's identifier as stored:
    a fourcc, a Matroska codec ID, an FLV codec name), `frame_count`, `duration` (s),
    `width`, `height`, `fps`, `file_size` (bytes), `tree` (the top-level `Node`s).
    """

    format: str
    codec: str | None
    frame_count: int | None
    duration: float | None
    width: int | None
    height: int | None
    fps: float | None
    file_size: int
    tree: list[Node]

    def row(self) -> dict:
        """The scalar fields as a dict (one row of a formats table)."""
        return {k: getattr(self, k) for k in ("format", "codec", "frame_count", "duration",
                                               "width", "height", "fps", "file_size")}


def format_tree(nodes: list[Node], *, max_children: int = 4, indent: str = "") -> str:
    """The box/chunk tree as indented text; long runs of same-named siblings are cut
    to `max_children` with a count of the rest."""
    lines = []
    i = 0
    while i < len(nodes):
        node = nodes[i]
        run = 1
        while i + run < len(nodes) and nodes[i + run].name == node.name:
            run += 1
        shown = nodes[i : i + min(run, max_children)]
        for n in shown:
            fields = ", ".join(f"{k}={v}" for k, v in n.fields.items())
            lines.append(f"{indent}{n.name} [{n.size} B]" + (f" {fields}" if fields else ""))
            if n.children:
                lines.append(format_tree(n.children, max_children=max_children,
                                         indent=indent + "  "))
        if run > len(shown):
            lines.append(f"{indent}... {run - len(shown)} more {node.name!r}")
        i += run
    return "\n".join(lines)


def container_info(path) -> ContainerInfo:
    """Parse a video container's structure (no ffmpeg): codec, frames, duration, size.

    Recognised by magic bytes: RIFF/AVI, ISO base media (MP4, MOV: `ftyp` box), FLV,
    EBML (WebM/Matroska), ASF (WMV) and GIF.

    **Returns:** a `ContainerInfo`. **Raises:** `ValueError` for an unknown or damaged file.
    """
    path = os.fspath(path)
    with open(path, "rb") as fh:
        data = fh.read()
    head = data[:16]
    try:
        if head[:4] == b"RIFF" and head[8:12] == b"AVI ":
            return _avi(data)
        if head[4:8] in (b"ftyp", b"moov", b"mdat", b"wide", b"free"):
            return _iso_bmff(data)
        if head[:3] == b"FLV":
            return _flv(data)
        if head[:4] == b"\x1a\x45\xdf\xa3":
            return _ebml(data)
        if head[:16] == _ASF_HEADER:
            return _asf(data)
        if head[:6] in (b"GIF87a", b"GIF89a"):
            return _gif(data)
    except (struct.error, IndexError, KeyError) as err:
        raise ValueError(f"{path!r}: damaged or truncated container ({err})") from err
    raise ValueError(
        f"{path!r} is not a recognised video container (AVI, MP4/MOV, FLV, WebM, WMV/ASF or "
        f"GIF); it starts with {head[:12]!r}"
    )


def _rate(frames, duration):
    return frames / duration if frames and duration else None


# ---- RIFF / AVI: little-endian chunks `id size data`, LIST chunks nest.

def _riff_chunks(data, start, end):
    nodes = []
    pos = start
    while pos + 8 <= end:
        cid = data[pos : pos + 4].decode("latin-1")
        size = struct.unpack_from("<I", data, pos + 4)[0]
        body = pos + 8
        if cid in ("RIFF", "LIST"):
            kind = data[body : body + 4].decode("latin-1")
            node = Node(f"{cid}:{kind}", pos, size + 8)
            node.children = _riff_chunks(data, body + 4, min(body + size, end))
        else:
            node = Node(cid, pos, size + 8)
            node.fields = _riff_fields(cid, data[body : body + size])
        nodes.append(node)
        pos = body + size + (size & 1)
    return nodes


def _riff_fields(cid, body):
    if cid == "avih" and len(body) >= 40:
        us, _, _, _, total, _, streams, _, w, h = struct.unpack_from("<10I", body)
        return {"us_per_frame": us, "total_frames": total, "streams": streams, "width": w,
                "height": h}
    if cid == "strh" and len(body) >= 36:
        kind, handler = body[:4].decode("latin-1"), body[4:8].decode("latin-1")
        scale, rate, _, length = struct.unpack_from("<4I", body, 20)
        return {"type": kind, "handler": handler, "scale": scale, "rate": rate,
                "length": length}
    if cid == "strf" and len(body) >= 20:
        _, w, h, _, bits = struct.unpack_from("<IiiHH", body)
        return {"width": w, "height": abs(h), "bits": bits,
                "compression": body[16:20].decode("latin-1")}
    return {}


def _walk(nodes):
    for n in nodes:
        yield n
        yield from _walk(n.children)


def _avi(data):
    tree = _riff_chunks(data, 0, len(data))
    nodes = list(_walk(tree))
    avih = next(n.fields for n in nodes if n.name == "avih")
    video = None
    for n in nodes:
        if n.name == "LIST:strl":
            strh = next((c.fields for c in n.children if c.name == "strh"), {})
            if strh.get("type") == "vids":
                video = (strh, next((c.fields for c in n.children if c.name == "strf"), {}))
                break
    movi = next((n for n in nodes if n.name == "LIST:movi"), None)
    frames = None
    if movi is not None:
        frames = sum(1 for c in movi.children if c.name[2:] in ("dc", "db"))
    if not frames:
        frames = video[0]["length"] if video else avih["total_frames"]
    fps = video[0]["rate"] / video[0]["scale"] if video and video[0]["scale"] else (
        1e6 / avih["us_per_frame"] if avih["us_per_frame"] else None)
    codec = video[1].get("compression") if video else None
    return ContainerInfo("AVI", codec, frames, frames / fps if fps else None, avih["width"],
                         avih["height"], fps, len(data), tree)


# ---- ISO base media file format (MP4, MOV): big-endian boxes `size type data`.

_ISO_CONTAINERS = {"moov", "trak", "mdia", "minf", "stbl", "edts", "dinf", "mvex", "udta"}


def _iso_boxes(data, start, end):
    nodes = []
    pos = start
    while pos + 8 <= end:
        size, kind = struct.unpack_from(">I4s", data, pos)
        header = 8
        if size == 1:
            size = struct.unpack_from(">Q", data, pos + 8)[0]
            header = 16
        elif size == 0:
            size = end - pos
        if size < header:
            raise ValueError(f"box at byte {pos} has an invalid size {size}")
        name = kind.decode("latin-1")
        node = Node(name, pos, size)
        body = data[pos + header : pos + size]
        if name in _ISO_CONTAINERS:
            node.children = _iso_boxes(data, pos + header, min(pos + size, end))
        else:
            node.fields = _iso_fields(name, body)
        nodes.append(node)
        pos += size
    return nodes


def _iso_fields(name, body):
    if name == "ftyp":
        return {"major_brand": body[:4].decode("latin-1"),
                "compatible": ",".join(body[i : i + 4].decode("latin-1")
                                       for i in range(8, len(body) - 3, 4))}
    if name in ("mvhd", "mdhd"):
        if body[0] == 1:
            timescale, duration = struct.unpack_from(">IQ", body, 20)
        else:
            timescale, duration = struct.unpack_from(">II", body, 12)
        return {"timescale": timescale, "duration": duration}
    if name == "tkhd":
        w, h = struct.unpack_from(">II", body, len(body) - 8)
        return {"width": w / 65536, "height": h / 65536}
    if name == "hdlr":
        return {"handler": body[8:12].decode("latin-1")}
    if name == "stsd":
        count = struct.unpack_from(">I", body, 4)[0]
        fields = {"entries": count}
        if count:
            fields["format"] = body[12:16].decode("latin-1")
            if len(body) >= 8 + 36:
                fields["width"], fields["height"] = struct.unpack_from(">HH", body, 8 + 32)
        return fields
    if name == "stsz":
        sample_size, count = struct.unpack_from(">II", body, 4)
        return {"sample_size": sample_size, "sample_count": count}
    if name == "stts":
        entries = struct.unpack_from(">I", body, 4)[0]
        pairs = [struct.unpack_from(">II", body, 8 + 8 * i) for i in range(entries)]
        return {"entries": entries, "samples": sum(c for c, _ in pairs)}
    return {}


def _iso_bmff(data):
    tree = _iso_boxes(data, 0, len(data))
    ftyp = next((n for n in tree if n.name == "ftyp"), None)
    brand = ftyp.fields["major_brand"] if ftyp else ""
    fmt = "MOV" if brand.startswith("qt") else "MP4"
    moov = next((n for n in tree if n.name == "moov"), None)
    if moov is None:
        raise ValueError("no 'moov' box: not a complete MP4/MOV file")
    mvhd = next(c.fields for c in moov.children if c.name == "mvhd")
    duration = mvhd["duration"] / mvhd["timescale"] if mvhd["timescale"] else None
    codec = frames = width = height = fps = None
    for trak in (c for c in moov.children if c.name == "trak"):
        boxes = {n.name: n.fields for n in _walk(trak.children)}
        mdia = next((c for c in trak.children if c.name == "mdia"), None)
        # The media handler is mdia/hdlr (QuickTime also has a data handler in minf).
        handler = next((c.fields.get("handler") for c in (mdia.children if mdia else [])
                        if c.name == "hdlr"), None)
        if handler != "vide":
            continue
        codec = boxes.get("stsd", {}).get("format")
        frames = boxes.get("stsz", {}).get("sample_count", boxes.get("stts", {}).get("samples"))
        width, height = int(boxes["tkhd"]["width"]), int(boxes["tkhd"]["height"])
        mdhd = boxes.get("mdhd")
        if mdhd and mdhd["timescale"]:
            fps = _rate(frames, mdhd["duration"] / mdhd["timescale"])
        break
    return ContainerInfo(fmt, codec, frames, duration, width, height, fps, len(data), tree)


# ---- FLV: a 9-byte header, then tags `type size(3) timestamp(3+1) stream(3) data`.

_FLV_CODECS = {2: "Sorenson H.263 (FLV1)", 3: "Screen video", 4: "VP6", 5: "VP6 alpha",
               6: "Screen video 2", 7: "AVC (H.264)"}


def _amf0(data, pos):
    kind = data[pos]
    pos += 1
    if kind == 0:
        return struct.unpack_from(">d", data, pos)[0], pos + 8
    if kind == 1:
        return bool(data[pos]), pos + 1
    if kind == 2:
        n = struct.unpack_from(">H", data, pos)[0]
        return data[pos + 2 : pos + 2 + n].decode("utf-8", "replace"), pos + 2 + n
    if kind in (3, 8):
        if kind == 8:
            pos += 4  # approximate count; the end marker is authoritative
        out = {}
        while data[pos : pos + 3] != b"\x00\x00\x09":
            n = struct.unpack_from(">H", data, pos)[0]
            key = data[pos + 2 : pos + 2 + n].decode("utf-8", "replace")
            out[key], pos = _amf0(data, pos + 2 + n)
        return out, pos + 3
    if kind == 10:
        count = struct.unpack_from(">I", data, pos)[0]
        pos += 4
        items = []
        for _ in range(count):
            item, pos = _amf0(data, pos)
            items.append(item)
        return items, pos
    if kind in (5, 6):
        return None, pos
    if kind == 11:
        return struct.unpack_from(">d", data, pos)[0], pos + 10
    if kind == 12:
        n = struct.unpack_from(">I", data, pos)[0]
        return data[pos + 4 : pos + 4 + n].decode("utf-8", "replace"), pos + 4 + n
    raise ValueError(f"unsupported AMF0 value type {kind}")


def _flv(data):
    version, flags, header_size = struct.unpack_from(">BBI", data, 3)
    tree = [Node("header", 0, header_size, fields={"version": version,
                                                    "video": bool(flags & 1),
                                                    "audio": bool(flags & 4)})]
    pos = header_size + 4  # PreviousTagSize0
    frames, codec, meta, last_ts = 0, None, {}, 0
    names = {8: "audio", 9: "video", 18: "script"}
    while pos + 11 <= len(data):
        kind = data[pos] & 0x1F
        size = int.from_bytes(data[pos + 1 : pos + 4], "big")
        ts = int.from_bytes(data[pos + 4 : pos + 7], "big") | (data[pos + 7] << 24)
        body = data[pos + 11 : pos + 11 + size]
        node = Node(names.get(kind, f"tag{kind}"), pos, 11 + size, fields={"time_ms": ts})
        if kind == 9 and body:
            codec_id = body[0] & 0x0F
            codec = _FLV_CODECS.get(codec_id, f"codec {codec_id}")
            # AVC sends a configuration packet (type 0) and end-of-sequence (2): not frames.
            if codec_id != 7 or (len(body) > 1 and body[1] == 1):
                frames += 1
                last_ts = max(last_ts, ts)
            node.fields["frame_type"] = body[0] >> 4
        elif kind == 18:
            name, p = _amf0(body, 0)
            value, _ = _amf0(body, p)
            node.name = f"script:{name}"
            if name == "onMetaData" and isinstance(value, dict):
                meta = value
                node.fields.update({k: v for k, v in value.items()
                                    if k in ("duration", "width", "height", "framerate")})
        tree.append(node)
        pos += 11 + size + 4
    fps = meta.get("framerate") or None
    duration = meta.get("duration") or (frames / fps if fps else last_ts / 1000)
    width, height = meta.get("width"), meta.get("height")
    return ContainerInfo("FLV", codec, frames, duration, int(width) if width else None,
                         int(height) if height else None, fps, len(data), tree)


# ---- EBML (WebM / Matroska): elements `id(vint) size(vint) data`.

_EBML_MASTERS = {
    0x1A45DFA3: "EBML", 0x18538067: "Segment", 0x114D9B74: "SeekHead", 0x4DBB: "Seek",
    0x1549A966: "Info", 0x1654AE6B: "Tracks", 0xAE: "TrackEntry", 0xE0: "Video",
    0x1F43B675: "Cluster", 0xA0: "BlockGroup", 0x1C53BB6B: "Cues", 0xBB: "CuePoint",
    0xB7: "CueTrackPositions", 0x1254C367: "Tags", 0x7373: "Tag", 0x67C8: "SimpleTag",
    0x63C0: "Targets",
}
_EBML_LEAVES = {
    0x4282: ("DocType", "str"), 0x2AD7B1: ("TimecodeScale", "uint"),
    0x4489: ("Duration", "float"), 0xD7: ("TrackNumber", "uint"), 0x83: ("TrackType", "uint"),
    0x86: ("CodecID", "str"), 0xB0: ("PixelWidth", "uint"), 0xBA: ("PixelHeight", "uint"),
    0x23E383: ("DefaultDuration", "uint"), 0xE7: ("Timecode", "uint"),
    0xA3: ("SimpleBlock", "block"), 0xA1: ("Block", "block"), 0xEC: ("Void", None),
    0x4286: ("EBMLVersion", "uint"), 0x42F7: ("EBMLReadVersion", "uint"),
    0x42F2: ("EBMLMaxIDLength", "uint"), 0x42F3: ("EBMLMaxSizeLength", "uint"),
    0x4287: ("DocTypeVersion", "uint"), 0x4285: ("DocTypeReadVersion", "uint"),
    0x53AB: ("SeekID", None), 0x53AC: ("SeekPosition", "uint"), 0x4D80: ("MuxingApp", "str"),
    0x5741: ("WritingApp", "str"), 0x73C5: ("TrackUID", None), 0x9C: ("FlagLacing", "uint"),
    0x22B59C: ("Language", "str"), 0x88: ("FlagDefault", "uint"), 0x63A2: ("CodecPrivate", None),
    0x9A: ("FlagInterlaced", "uint"), 0x55B0: ("Colour", None), 0x55EE: ("MaxBlockAddID", None),
    0xB3: ("CueTime", "uint"), 0xF7: ("CueTrack", "uint"), 0xF1: ("CueClusterPosition", "uint"),
    0xF0: ("CueRelativePosition", "uint"), 0x45A3: ("TagName", "str"),
    0x4487: ("TagString", "str"), 0x63C5: ("TagTrackUID", None),
}


def _vint(data, pos, keep_marker):
    first = data[pos]
    length = 1
    while length <= 8 and not first & (0x80 >> (length - 1)):
        length += 1
    if length > 8:
        raise ValueError(f"invalid EBML variable-length integer at byte {pos}")
    value = first if keep_marker else first & (0xFF >> length)
    for b in data[pos + 1 : pos + length]:
        value = (value << 8) | b
    unknown = not keep_marker and value == (1 << (7 * length)) - 1
    return value, pos + length, unknown


def _ebml_elements(data, start, end):
    nodes = []
    pos = start
    while pos < end:
        eid, p, _ = _vint(data, pos, True)
        size, body, unknown = _vint(data, p, False)
        stop = end if unknown else min(body + size, end)
        if eid in _EBML_MASTERS:
            node = Node(_EBML_MASTERS[eid], pos, stop - pos)
            node.children = _ebml_elements(data, body, stop)
        else:
            name, kind = _EBML_LEAVES.get(eid, (f"0x{eid:X}", None))
            node = Node(name, pos, stop - pos)
            raw = data[body:stop]
            if kind == "uint":
                node.fields["value"] = int.from_bytes(raw, "big")
            elif kind == "str":
                node.fields["value"] = raw.rstrip(b"\x00").decode("utf-8", "replace")
            elif kind == "float":
                node.fields["value"] = struct.unpack(">f" if len(raw) == 4 else ">d", raw)[0]
            elif kind == "block":
                node.fields["track"] = _vint(raw, 0, False)[0]
        nodes.append(node)
        pos = stop
    return nodes


def _ebml(data):
    tree = _ebml_elements(data, 0, len(data))
    nodes = list(_walk(tree))
    doc = next((n.fields["value"] for n in nodes if n.name == "DocType"), "matroska")
    scale = next((n.fields["value"] for n in nodes if n.name == "TimecodeScale"), 1_000_000)
    duration = next((n.fields["value"] for n in nodes if n.name == "Duration"), None)
    duration = duration * scale / 1e9 if duration is not None else None
    codec = width = height = fps = None
    track_no = None
    for entry in (n for n in nodes if n.name == "TrackEntry"):
        f = {c.name: c.fields.get("value") for c in _walk(entry.children)}
        if f.get("TrackType") == 1:
            track_no, codec = f.get("TrackNumber"), f.get("CodecID")
            width, height = f.get("PixelWidth"), f.get("PixelHeight")
            if f.get("DefaultDuration"):
                fps = 1e9 / f["DefaultDuration"]
            break
    frames = sum(1 for n in nodes if n.name in ("SimpleBlock", "Block")
                 and (track_no is None or n.fields["track"] == track_no))
    fps = fps or _rate(frames, duration)
    return ContainerInfo("WebM" if doc == "webm" else "Matroska", codec, frames, duration,
                         width, height, fps, len(data), tree)


# ---- ASF (WMV): objects `GUID(16) size(8, LE) data`; frames counted in data packets.

def _guid(text):
    import uuid

    return uuid.UUID(text).bytes_le


_ASF_HEADER = _guid("75B22630-668E-11CF-A6D9-00AA0062CE6C")
_ASF_NAMES = {
    _ASF_HEADER: "Header",
    _guid("75B22636-668E-11CF-A6D9-00AA0062CE6C"): "Data",
    _guid("33000890-E5B1-11CF-89F4-00A0C90349CB"): "SimpleIndex",
    _guid("8CABDCA1-A947-11CF-8EE4-00C00C205365"): "FileProperties",
    _guid("B7DC0791-A9B7-11CF-8EE6-00C00C205365"): "StreamProperties",
    _guid("5FBF03B5-A92E-11CF-8EE3-00C00C205365"): "HeaderExtension",
    _guid("86D15240-311D-11D0-A3A4-00A0C90348F6"): "CodecList",
    _guid("75B22633-668E-11CF-A6D9-00AA0062CE6C"): "ContentDescription",
    _guid("D2D0A440-E307-11D2-97F0-00A0C95EA850"): "ExtendedContentDescription",
    _guid("7BF875CE-468D-11D1-8D82-006097C9A2B2"): "StreamBitrateProperties",
    _guid("1806D474-CADF-4509-A4BA-9AABCB96AAE8"): "Padding",
}
_ASF_VIDEO = _guid("BC19EFC0-5B4D-11CF-A8FD-00805F5C442B")


def _asf_objects(data, start, end, count=None):
    nodes = []
    pos = start
    while pos + 24 <= end and (count is None or len(nodes) < count):
        guid = data[pos : pos + 16]
        size = struct.unpack_from("<Q", data, pos + 16)[0]
        if size < 24:
            raise ValueError(f"ASF object at byte {pos} has an invalid size {size}")
        name = _ASF_NAMES.get(guid, "Unknown")
        node = Node(name, pos, size)
        body = data[pos + 24 : pos + size]
        if name == "Header":
            n = struct.unpack_from("<I", body, 0)[0]
            node.children = _asf_objects(data, pos + 30, pos + size, n)
        elif name == "FileProperties":
            packets, play, _, preroll, _, min_packet = struct.unpack_from("<QQQQII", body, 32)
            node.fields = {"packets": packets, "play_duration": play, "preroll_ms": preroll,
                           "packet_size": min_packet}
        elif name == "StreamProperties":
            number = struct.unpack_from("<H", body, 48)[0] & 0x7F
            node.fields = {"stream": number, "video": body[:16] == _ASF_VIDEO}
            if node.fields["video"]:
                w, h = struct.unpack_from("<II", body, 54)
                node.fields.update(width=w, height=h,
                                   compression=body[54 + 11 + 16 : 54 + 11 + 20].decode("latin-1"))
        nodes.append(node)
        pos += size
    return nodes


def _asf_count_frames(data, start, end, packet_size, stream):
    """Count video media objects: payloads of `stream` that start an object (offset 0)."""
    sizes = {0: 0, 1: 1, 2: 2, 3: 4}
    pos = start
    frames = 0

    def read(p, length_type):
        n = sizes[length_type]
        return (int.from_bytes(data[p : p + n], "little") if n else 0), p + n

    while pos + packet_size <= end and packet_size > 0:
        p = pos
        flags = data[p]
        if flags & 0x80:  # error correction data present
            p += 1 + (flags & 0x0F)
        length_flags, prop_flags = data[p], data[p + 1]
        p += 2
        _, p = read(p, (length_flags >> 5) & 3)  # packet length
        _, p = read(p, (length_flags >> 1) & 3)  # sequence
        _, p = read(p, (length_flags >> 3) & 3)  # padding length
        p += 6  # send time, duration
        multiple = length_flags & 1
        count, payload_len_type = 1, 2
        if multiple:
            count, payload_len_type = data[p] & 0x3F, (data[p] >> 6) & 3
            p += 1
        for _ in range(count):
            number = data[p] & 0x7F
            p += 1
            _, p = read(p, (prop_flags >> 4) & 3)  # media object number
            offset, p = read(p, (prop_flags >> 2) & 3)
            rep_len, p = read(p, prop_flags & 3)
            p += rep_len
            if multiple:
                payload, p = read(p, payload_len_type)
                p += payload
            # A media object (frame) may span payloads; count only its first piece.
            if number == stream and offset == 0 and rep_len != 1:
                frames += 1
            if not multiple:
                break
        pos += packet_size
    return frames


def _asf(data):
    tree = _asf_objects(data, 0, len(data))
    nodes = list(_walk(tree))
    props = next(n.fields for n in nodes if n.name == "FileProperties")
    video = next((n.fields for n in nodes if n.name == "StreamProperties"
                  and n.fields.get("video")), None)
    duration = max(props["play_duration"] / 1e7 - props["preroll_ms"] / 1e3, 0.0)
    frames = None
    data_obj = next((n for n in tree if n.name == "Data"), None)
    if data_obj is not None and video is not None:
        frames = _asf_count_frames(data, data_obj.offset + 50, data_obj.offset + data_obj.size,
                                   props["packet_size"], video["stream"])
        data_obj.fields["packets"] = props["packets"]
    codec = video["compression"] if video else None
    width, height = (video["width"], video["height"]) if video else (None, None)
    return ContainerInfo("WMV/ASF", codec, frames, duration, width, height,
                         _rate(frames, duration), len(data), tree)


# ---- GIF: header, logical screen, then extension / image blocks up to the trailer.

def _gif_sub_blocks(data, pos):
    while data[pos]:
        pos += 1 + data[pos]
    return pos + 1


def _gif(data):
    width, height, packed = struct.unpack_from("<HHB", data, 6)
    tree = [Node("header", 0, 6, fields={"version": data[:6].decode("latin-1")}),
            Node("logical_screen", 6, 7, fields={"width": width, "height": height})]
    pos = 13
    if packed & 0x80:
        size = 3 * 2 ** ((packed & 7) + 1)
        tree.append(Node("global_color_table", pos, size, fields={"colours": size // 3}))
        pos += size
    frames, delay_total = 0, 0
    while pos < len(data):
        marker = data[pos]
        if marker == 0x3B:
            tree.append(Node("trailer", pos, 1))
            break
        if marker == 0x21:
            label = data[pos + 1]
            end = _gif_sub_blocks(data, pos + 2)
            if label == 0xF9:
                delay = struct.unpack_from("<H", data, pos + 4)[0]
                delay_total += delay
                tree.append(Node("graphic_control", pos, end - pos, fields={"delay_cs": delay}))
            elif label == 0xFF:
                app = data[pos + 3 : pos + 14].decode("latin-1")
                tree.append(Node("application", pos, end - pos, fields={"id": app}))
            else:
                tree.append(Node(f"extension_0x{label:02X}", pos, end - pos))
            pos = end
        elif marker == 0x2C:
            w, h, flags = struct.unpack_from("<HHB", data, pos + 5)
            start = pos
            pos += 10
            if flags & 0x80:
                pos += 3 * 2 ** ((flags & 7) + 1)
            pos = _gif_sub_blocks(data, pos + 1)  # LZW minimum code size, then data
            tree.append(Node("image", start, pos - start, fields={"width": w, "height": h}))
            frames += 1
        else:
            raise ValueError(f"unexpected GIF block 0x{marker:02X} at byte {pos}")
    duration = delay_total / 100 if delay_total else None
    return ContainerInfo("GIF", "GIF (LZW)", frames, duration, width, height,
                         _rate(frames, duration), len(data), tree)

