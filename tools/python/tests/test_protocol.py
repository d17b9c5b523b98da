"""Tests of the Python decoder against bytes produced by the C++ encoder (the golden fixture
host_tests/data/protocol_golden.bin, which protocol_test.cpp checks the encoder reproduces)."""
import os
import random
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from ballvision_link import BallState, Decoder, StatusReport, cobs_decode, cobs_encode  # noqa
from ballvision_link.protocol import encode_frame, MSG_BALL_STATE  # noqa

FIXTURE = os.path.join(os.path.dirname(__file__), "..", "..", "..", "host_tests", "data",
                       "protocol_golden.bin")


class ProtocolTest(unittest.TestCase):
    def test_decodes_cpp_stream(self):
        data = open(FIXTURE, "rb").read()
        msgs = list(Decoder().feed(data))
        self.assertEqual(len(msgs), 2)
        ball, status = msgs
        self.assertIsInstance(ball, BallState)
        self.assertEqual(ball.seq, 41)
        self.assertEqual(ball.t_us, 1000000)
        self.assertEqual(ball.mode, "rolling")
        self.assertAlmostEqual(ball.y, 3.5)
        self.assertAlmostEqual(ball.omni_u, 100.5)
        self.assertEqual(ball.t_bounce_us, 1250000)
        self.assertIsInstance(status, StatusReport)
        self.assertEqual(status.frames_processed, 30)
        self.assertAlmostEqual(status.frame_rate_hz, 30.0)
        self.assertEqual(status.calibration_id, 0x1234)
        self.assertEqual((status.rx_overruns, status.rx_ring_full, status.rx_line_errors),
                         (1, 2, 3))

    def test_python_encoder_matches_cpp_bytes(self):
        data = open(FIXTURE, "rb").read()
        first = data[:data.index(0) + 1]
        raw = cobs_decode(first[:-1])
        payload = raw[10:-4]
        self.assertEqual(encode_frame(MSG_BALL_STATE, 41, payload), first)

    def test_cobs_round_trip(self):
        rng = random.Random(3)
        for n in list(range(0, 600, 7)) + [253, 254, 255, 508]:
            d = bytes(rng.choice([0, 1, 7, 255]) for _ in range(n))
            enc = cobs_encode(d)
            self.assertNotIn(0, enc)
            self.assertEqual(cobs_decode(enc), d)

    def test_corruption_never_accepted(self):
        data = open(FIXTURE, "rb").read()
        rng = random.Random(7)
        for _ in range(2000):
            b = bytearray(data * 3)
            i = rng.randrange(len(b))
            b[i] ^= rng.randrange(1, 256)
            for m in Decoder().feed(bytes(b)):
                if isinstance(m, BallState):
                    self.assertEqual(m.t_us, 1000000)
                    self.assertAlmostEqual(m.y, 3.5)
                elif isinstance(m, StatusReport):
                    self.assertEqual(m.frames_processed, 30)


if __name__ == "__main__":
    unittest.main()


class CommandsTest(unittest.TestCase):
    def test_upload_frames_decode_in_order(self):
        from ballvision_link import commands
        blob = bytes(range(256)) * 5
        frames = commands.upload(10, commands.TARGET_LUT, blob)
        self.assertEqual(len(frames), 1 + 3 + 1)
        msgs = list(Decoder().feed(b"".join(frames)))
        self.assertEqual([m[0] for m in msgs], [0x22, 0x23, 0x23, 0x23, 0x24])
        self.assertEqual([m[1] for m in msgs], list(range(10, 15)))
        self.assertEqual(b"".join(m[2][5:] for m in msgs[1:4]), blob)
