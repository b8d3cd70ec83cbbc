"""Video container structure, parsed directly (no ffmpeg): the tree model, RIFF/AVI and
ISO base media (MP4, MOV). `gfxlab.animation.container_info` dispatches here."""

from __future__ import annotations

import dataclasses
import struct


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
        return {
            k: getattr(self, k)
            for k in (
                "format",
                "codec",
                "frame_count",
                "duration",
                "width",
                "height",
                "fps",
                "file_size",
            )
        }


def format_tree(nodes: list[Node], *, max_children: int = 4) -> str:
    """The box/chunk tree as indented text; long runs of same-named siblings are cut
    to `max_children` (1..`MAX_SHOWN_CHILDREN`) with a count of the rest."""
    if isinstance(nodes, Node) or not isinstance(nodes, list | tuple):
        raise TypeError(f"`nodes` must be a list of Node (ContainerInfo.tree), got {nodes!r:.60}")
    if not all(isinstance(n, Node) for n in nodes):
        raise TypeError("`nodes` must hold only Node entries (ContainerInfo.tree)")
    if isinstance(max_children, bool) or not isinstance(max_children, int):
        raise TypeError(f"`max_children` must be an int, got {max_children!r:.40}")
    if not 1 <= max_children <= MAX_SHOWN_CHILDREN:
        raise ValueError(f"`max_children` must be in [1, {MAX_SHOWN_CHILDREN}], got {max_children}")
    return _format_tree(nodes, max_children, "")


#: The most same-named siblings `format_tree` shows before cutting a run.
MAX_SHOWN_CHILDREN = 100_000


def _format_tree(nodes, max_children: int, indent: str) -> str:
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
                lines.append(_format_tree(n.children, max_children, indent + "  "))
        if run > len(shown):
            lines.append(f"{indent}... {run - len(shown)} more {node.name!r}")
        i += run
    return "\n".join(lines)


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
        return {
            "us_per_frame": us,
            "total_frames": total,
            "streams": streams,
            "width": w,
            "height": h,
        }
    if cid == "strh" and len(body) >= 36:
        kind, handler = body[:4].decode("latin-1"), body[4:8].decode("latin-1")
        scale, rate, _, length = struct.unpack_from("<4I", body, 20)
        return {"type": kind, "handler": handler, "scale": scale, "rate": rate, "length": length}
    if cid == "strf" and len(body) >= 20:
        _, w, h, _, bits = struct.unpack_from("<IiiHH", body)
        return {
            "width": w,
            "height": abs(h),
            "bits": bits,
            "compression": body[16:20].decode("latin-1"),
        }
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
    fps = (
        video[0]["rate"] / video[0]["scale"]
        if video and video[0]["scale"]
        else (1e6 / avih["us_per_frame"] if avih["us_per_frame"] else None)
    )
    codec = video[1].get("compression") if video else None
    return ContainerInfo(
        "AVI",
        codec,
        frames,
        frames / fps if fps else None,
        avih["width"],
        avih["height"],
        fps,
        len(data),
        tree,
    )


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
        return {
            "major_brand": body[:4].decode("latin-1"),
            "compatible": ",".join(
                body[i : i + 4].decode("latin-1") for i in range(8, len(body) - 3, 4)
            ),
        }
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
        handler = next(
            (c.fields.get("handler") for c in (mdia.children if mdia else []) if c.name == "hdlr"),
            None,
        )
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
