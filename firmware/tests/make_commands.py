#!/usr/bin/env python3
"""Writes command frames for the firmware's UART input, in the wire format of core/protocol
(COBS(header | payload | crc32) 0x00). The schema hash is taken from a packet the firmware
sent (REFERENCE: a captured UART stream), so this never has to track the payload layouts.
  make_commands.py REFERENCE OUT
OUT gets: request-status, set-param(frame period = 20000 us), set-param(unknown id 77)."""
import struct
import sys
import zlib


def cobs_decode(data):
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        out += data[i + 1:i + code]
        i += code
        if code != 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def cobs_encode(data):
    out, block = bytearray(), bytearray()
    for b in data:
        if b == 0:
            out += bytes([len(block) + 1]) + block
            block = bytearray()
        else:
            block.append(b)
            if len(block) == 254:
                out += bytes([255]) + block
                block = bytearray()
    out += bytes([len(block) + 1]) + block
    return bytes(out)


def frame(version, schema, msg_type, seq, payload):
    raw = struct.pack("<BBHIH", version, msg_type, schema, seq, len(payload)) + payload
    raw += struct.pack("<I", zlib.crc32(raw) & 0xFFFFFFFF)
    return cobs_encode(raw) + b"\x00"


def main():
    ref = open(sys.argv[1], "rb").read()
    first = cobs_decode(ref[:ref.index(b"\x00")])
    version, _, schema = struct.unpack("<BBH", first[:4])
    out = frame(version, schema, 0x20, 1, b"")
    out += frame(version, schema, 0x21, 2, struct.pack("<Hf", 1, 20000.0))
    out += frame(version, schema, 0x21, 3, struct.pack("<Hf", 77, 1.0))
    open(sys.argv[2], "wb").write(out)


if __name__ == "__main__":
    main()
