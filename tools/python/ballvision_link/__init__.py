"""Decode the ballvision coprocessor's serial stream on the robot's main computer.

The wire format is described in docs/protocol.md: COBS frames delimited by 0x00, each holding
a 10-byte header (version, type, schema hash, sequence, payload length), the payload and a
CRC-32 (zlib.crc32). Only the standard library is needed to decode; pyserial to open a port.
"""
from .clock_sync import ClockSync
from .protocol import (BallState, BlobData, CaptureChunk, CaptureEnd, CaptureFrame, ClockSyncReply,
                       Decoder, Goals, LinePoints, Obstacles, Pose, StatusReport,
                       MSG_BALL_STATE, MSG_GOALS, MSG_LINE_POINTS, MSG_OBSTACLES, MSG_POSE,
                       MSG_STATUS, cobs_decode, cobs_encode, SCHEMA_HASH)

__all__ = ["BallState", "BlobData", "CaptureChunk", "CaptureEnd", "CaptureFrame", "ClockSync",
           "ClockSyncReply", "Decoder", "Goals", "LinePoints", "Obstacles", "Pose",
           "StatusReport", "MSG_BALL_STATE", "MSG_GOALS", "MSG_LINE_POINTS", "MSG_OBSTACLES",
           "MSG_POSE", "MSG_STATUS",
           "cobs_decode", "cobs_encode", "SCHEMA_HASH"]
