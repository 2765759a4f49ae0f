"""The XRCE-DDS wire as the probe's relays and the fleet read it (pure): the client's serial framing
(``0x7E``, source and destination address, a 16-bit little-endian length, the payload and a CRC-16,
with ``0x7D`` escaping ``0x7E``/``0x7D`` as ``0x7D, byte ^ 0x20``) and the messages inside a frame or a
UDP datagram (a header and 4-byte aligned submessages). uros reads its own figures of a link from
these bytes, never from the firmware's text.
"""

from __future__ import annotations

from dataclasses import dataclass

FLAG, ESCAPE, XOR = 0x7E, 0x7D, 0x20
HEADER = 4  # source, destination, length (2, little-endian), all after unescaping
CRC = 2


class Framer:
    """Cuts a byte stream into XRCE serial frames (each returned with its flag and escapes, as it
    was on the wire) and the bytes between them. Fed as bytes arrive."""

    def __init__(self) -> None:
        self.buffer = bytearray()

    def feed(self, data: bytes) -> list[tuple[bool, bytes]]:
        """(is a frame, its bytes) in order; an unfinished frame waits for more."""
        self.buffer += data
        out: list[tuple[bool, bytes]] = []
        while self.buffer:
            start = self.buffer.find(FLAG)
            if start != 0:
                loose = bytes(self.buffer if start < 0 else self.buffer[:start])
                out.append((False, loose))
                del self.buffer[: len(loose)]
                continue
            end = frame_end(self.buffer)
            if end is None:
                break
            out.append((True, bytes(self.buffer[:end])))
            del self.buffer[:end]
        return out


def frame_end(buf: bytes | bytearray) -> int | None:
    """Where the frame that starts at ``buf[0]`` (a flag) ends, or None: not all here (pure). A flag
    inside it (a frame cut short) ends it there: the next frame starts at that flag."""
    raw: list[int] = []
    i = 1
    while i < len(buf):
        byte = buf[i]
        if byte == FLAG:
            return i  # cut short: the receiver drops it, as it would
        if byte == ESCAPE:
            if i + 1 >= len(buf):
                return None
            byte = buf[i + 1] ^ XOR
            i += 1
        raw.append(byte)
        i += 1
        if len(raw) >= HEADER:
            length = raw[2] | raw[3] << 8
            if len(raw) == HEADER + length + CRC:
                return i
    return None


def unframe(frame: bytes) -> bytes | None:
    """The XRCE message a whole serial frame carries (escapes undone, its header and CRC cut), or
    None: not a whole frame (pure)."""
    raw = bytearray()
    i = 1
    while i < len(frame):
        byte = frame[i]
        if byte == ESCAPE and i + 1 < len(frame):
            i += 1
            byte = frame[i] ^ XOR
        raw.append(byte)
        i += 1
    if len(raw) < HEADER + CRC:
        return None
    length = raw[2] | raw[3] << 8
    if len(raw) != HEADER + length + CRC:
        return None
    return bytes(raw[HEADER : HEADER + length])


# XRCE-DDS (the client's src/c/core/session/submessage_internal.h, the XRCE spec): a message is a
# header (session id, stream id, a 16-bit little-endian sequence number, and the 4-byte client key
# when the session id is below 0x80), then submessages aligned to 4 bytes (id, flags, a 16-bit
# little-endian length, the payload). Stream 0 is none, 1-127 best-effort, 128-255 reliable.
CREATE_CLIENT, STATUS_AGENT, WRITE_DATA, DATA, TIMESTAMP, TIMESTAMP_REPLY = 0, 4, 7, 9, 14, 15
WITHOUT_KEY = 0x80
RELIABLE = 0x80


@dataclass(frozen=True)
class Message:
    session: int
    stream: int
    seq: int
    submessages: tuple[tuple[int, bytes], ...]  # (id, payload)


def parse_message(data: bytes) -> Message | None:
    """An XRCE message's header and submessages, or None: too short to be one (pure). A submessage
    that runs past the end is left out."""
    if len(data) < 4:
        return None
    session, stream, seq = data[0], data[1], data[2] | data[3] << 8
    at = 4 if session >= WITHOUT_KEY else 8
    subs = []
    while at + 4 <= len(data):
        kind, length = data[at], data[at + 2] | data[at + 3] << 8
        if at + 4 + length > len(data):
            break
        subs.append((kind, bytes(data[at + 4 : at + 4 + length])))
        at = (at + 4 + length + 3) & ~3
    return Message(session, stream, seq, tuple(subs))
