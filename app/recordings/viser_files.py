"""The .viser format (viser's `StateSerializer.serialize`): `read_recording` checks that bytes are a recording and
says what is in it, `viser_bytes` writes one from scene messages (a journal's, `app.recordings.journal`), and
`viser_html` wraps one into a page that plays it anywhere."""

from __future__ import annotations

import base64
from dataclasses import dataclass
from pathlib import Path

import msgspec
import viser
import zstandard


@dataclass(frozen=True)
class RecordingContents:
    """What a .viser file holds (see `read_recording`)."""

    duration_s: float
    viser_version: str
    messages: int
    node_names: frozenset[str]  # scene nodes created in it
    message_types: frozenset[str]


def read_recording(data: bytes, max_size: int = 2**31) -> RecordingContents:
    """Decode a .viser recording (viser's `StateSerializer.serialize` format: the payload size, then
    zstd of [msgpack length, msgpack {durationSeconds, messages, viserVersion, binaryBufferLengths},
    binary buffers]); ValueError if the bytes are not one."""
    if len(data) < 16:
        raise ValueError("not a .viser recording: too short")
    inner_size = int.from_bytes(data[:8], "little")
    if not 0 < inner_size <= max_size:
        raise ValueError(f"not a .viser recording: payload size {inner_size}")
    try:
        inner = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=inner_size)
    except zstandard.ZstdError as exc:
        raise ValueError(f"not a .viser recording: {exc}") from None
    if len(inner) != inner_size:
        raise ValueError(f"not a .viser recording: payload is {len(inner)} bytes, header says {inner_size}")
    header_size = int.from_bytes(inner[:8], "little")
    try:
        header = msgspec.msgpack.decode(inner[8 : 8 + header_size])
    except msgspec.DecodeError as exc:
        raise ValueError(f"not a .viser recording: {exc}") from None
    if not isinstance(header, dict) or not {"durationSeconds", "messages", "viserVersion"} <= header.keys():
        raise ValueError("not a .viser recording: header keys missing")
    messages = header["messages"]
    buffers = sum(header.get("binaryBufferLengths", ()))
    if buffers > inner_size:
        raise ValueError("not a .viser recording: binary buffers exceed the payload")
    times = [t for t, _ in messages]
    if any(b < a for a, b in zip(times, times[1:], strict=False)):
        raise ValueError("not a .viser recording: message times go backwards")
    return RecordingContents(
        duration_s=float(header["durationSeconds"]),
        viser_version=str(header["viserVersion"]),
        messages=len(messages),
        node_names=frozenset(
            m["name"] for _, m in messages if m.get("type") not in ("RemoveSceneNodeMessage",) and "name" in m
        ),
        message_types=frozenset(m.get("type", "") for _, m in messages),
    )


def viser_html(data: bytes, dark_mode: bool = False) -> str:
    """One self-contained HTML page that plays a .viser recording.

    This is what viser's `StateSerializer.as_html()` does with the bytes of `serialize()` (the
    client reads `window.__VISER_EMBED_DATA__`); the serializer can only serialize once, so we
    build the page from the saved bytes instead, any time later.
    """
    client_html = (Path(viser.__file__).parent / "client" / "build" / "index.html").read_text()
    script = (
        f'<script>window.__VISER_EMBED_DATA__="{base64.b64encode(data).decode("ascii")}";'
        f"window.__VISER_EMBED_CONFIG__={{darkMode:{'true' if dark_mode else 'false'}}};</script>"
    )
    head_end = client_html.index("</head>")
    return client_html[:head_end] + script + client_html[head_end:]


def viser_bytes(messages: list, buffers: list[bytes], duration_s: float) -> bytes:
    """A .viser recording of these scene messages (``[t, message]``, binary placeholders indexing ``buffers``):
    the format `read_recording` reads, without the serializer's deduplication of equal buffers."""
    payload = msgspec.msgpack.encode(
        {
            "durationSeconds": duration_s,
            "messages": messages,
            "viserVersion": viser.__version__,
            "binaryBufferLengths": [len(b) for b in buffers],
        }
    )
    parts = [len(payload).to_bytes(8, "little"), payload]
    offset = 8 + len(payload)
    for buf in buffers:  # 8-byte aligned, as the client reads them
        padding = (8 - offset % 8) % 8
        parts += [b"\0" * padding, buf]
        offset += padding + len(buf)
    inner = b"".join(parts)
    return len(inner).to_bytes(8, "little") + zstandard.ZstdCompressor(level=3).compress(inner)
