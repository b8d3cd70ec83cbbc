"""Video container structure, continued: FLV tags, EBML (WebM), ASF (WMV), GIF blocks."""

from __future__ import annotations

import struct

from ._containers import ContainerInfo, Node, _rate, _walk

# ---- FLV: a 9-byte header, then tags `type size(3) timestamp(3+1) stream(3) data`.

_FLV_CODECS = {
    2: "Sorenson H.263 (FLV1)",
    3: "Screen video",
    4: "VP6",
    5: "VP6 alpha",
    6: "Screen video 2",
    7: "AVC (H.264)",
}


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
    tree = [
        Node(
            "header",
            0,
            header_size,
            fields={"version": version, "video": bool(flags & 1), "audio": bool(flags & 4)},
        )
    ]
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
                node.fields.update(
                    {
                        k: v
                        for k, v in value.items()
                        if k in ("duration", "width", "height", "framerate")
                    }
                )
        tree.append(node)
        pos += 11 + size + 4
    fps = meta.get("framerate") or None
    duration = meta.get("duration") or (frames / fps if fps else last_ts / 1000)
    width, height = meta.get("width"), meta.get("height")
    return ContainerInfo(
        "FLV",
        codec,
        frames,
        duration,
        int(width) if width else None,
        int(height) if height else None,
        fps,
        len(data),
        tree,
    )


# ---- EBML (WebM / Matroska): elements `id(vint) size(vint) data`.

_EBML_MASTERS = {
    0x1A45DFA3: "EBML",
    0x18538067: "Segment",
    0x114D9B74: "SeekHead",
    0x4DBB: "Seek",
    0x1549A966: "Info",
    0x1654AE6B: "Tracks",
    0xAE: "TrackEntry",
    0xE0: "Video",
    0x1F43B675: "Cluster",
    0xA0: "BlockGroup",
    0x1C53BB6B: "Cues",
    0xBB: "CuePoint",
    0xB7: "CueTrackPositions",
    0x1254C367: "Tags",
    0x7373: "Tag",
    0x67C8: "SimpleTag",
    0x63C0: "Targets",
}
_EBML_LEAVES = {
    0x4282: ("DocType", "str"),
    0x2AD7B1: ("TimecodeScale", "uint"),
    0x4489: ("Duration", "float"),
    0xD7: ("TrackNumber", "uint"),
    0x83: ("TrackType", "uint"),
    0x86: ("CodecID", "str"),
    0xB0: ("PixelWidth", "uint"),
    0xBA: ("PixelHeight", "uint"),
    0x23E383: ("DefaultDuration", "uint"),
    0xE7: ("Timecode", "uint"),
    0xA3: ("SimpleBlock", "block"),
    0xA1: ("Block", "block"),
    0xEC: ("Void", None),
    0x4286: ("EBMLVersion", "uint"),
    0x42F7: ("EBMLReadVersion", "uint"),
    0x42F2: ("EBMLMaxIDLength", "uint"),
    0x42F3: ("EBMLMaxSizeLength", "uint"),
    0x4287: ("DocTypeVersion", "uint"),
    0x4285: ("DocTypeReadVersion", "uint"),
    0x53AB: ("SeekID", None),
    0x53AC: ("SeekPosition", "uint"),
    0x4D80: ("MuxingApp", "str"),
    0x5741: ("WritingApp", "str"),
    0x73C5: ("TrackUID", None),
    0x9C: ("FlagLacing", "uint"),
    0x22B59C: ("Language", "str"),
    0x88: ("FlagDefault", "uint"),
    0x63A2: ("CodecPrivate", None),
    0x9A: ("FlagInterlaced", "uint"),
    0x55B0: ("Colour", None),
    0x55EE: ("MaxBlockAddID", None),
    0xB3: ("CueTime", "uint"),
    0xF7: ("CueTrack", "uint"),
    0xF1: ("CueClusterPosition", "uint"),
    0xF0: ("CueRelativePosition", "uint"),
    0x45A3: ("TagName", "str"),
    0x4487: ("TagString", "str"),
    0x63C5: ("TagTrackUID", None),
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
    frames = sum(
        1
        for n in nodes
        if n.name in ("SimpleBlock", "Block")
        and (track_no is None or n.fields["track"] == track_no)
    )
    fps = fps or _rate(frames, duration)
    return ContainerInfo(
        "WebM" if doc == "webm" else "Matroska",
        codec,
        frames,
        duration,
        width,
        height,
        fps,
        len(data),
        tree,
    )


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
            node.fields = {
                "packets": packets,
                "play_duration": play,
                "preroll_ms": preroll,
                "packet_size": min_packet,
            }
        elif name == "StreamProperties":
            number = struct.unpack_from("<H", body, 48)[0] & 0x7F
            node.fields = {"stream": number, "video": body[:16] == _ASF_VIDEO}
            if node.fields["video"]:
                w, h = struct.unpack_from("<II", body, 54)
                node.fields.update(
                    width=w,
                    height=h,
                    compression=body[54 + 11 + 16 : 54 + 11 + 20].decode("latin-1"),
                )
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
    video = next(
        (n.fields for n in nodes if n.name == "StreamProperties" and n.fields.get("video")), None
    )
    duration = max(props["play_duration"] / 1e7 - props["preroll_ms"] / 1e3, 0.0)
    frames = None
    data_obj = next((n for n in tree if n.name == "Data"), None)
    if data_obj is not None and video is not None:
        frames = _asf_count_frames(
            data,
            data_obj.offset + 50,
            data_obj.offset + data_obj.size,
            props["packet_size"],
            video["stream"],
        )
        data_obj.fields["packets"] = props["packets"]
    codec = video["compression"] if video else None
    width, height = (video["width"], video["height"]) if video else (None, None)
    return ContainerInfo(
        "WMV/ASF", codec, frames, duration, width, height, _rate(frames, duration), len(data), tree
    )


# ---- GIF: header, logical screen, then extension / image blocks up to the trailer.


def _gif_sub_blocks(data, pos):
    while data[pos]:
        pos += 1 + data[pos]
    return pos + 1


def _gif(data):
    width, height, packed = struct.unpack_from("<HHB", data, 6)
    tree = [
        Node("header", 0, 6, fields={"version": data[:6].decode("latin-1")}),
        Node("logical_screen", 6, 7, fields={"width": width, "height": height}),
    ]
    pos = 13
    if packed & 0x80:
        size = 3 * 2 ** ((packed & 7) + 1)
        tree.append(Node("global_color_table", pos, size, fields={"colors": size // 3}))
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
    return ContainerInfo(
        "GIF",
        "GIF (LZW)",
        frames,
        duration,
        width,
        height,
        _rate(frames, duration),
        len(data),
        tree,
    )
