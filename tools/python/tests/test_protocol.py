"""Tests of the Python decoder against bytes produced by the C++ encoder (the golden fixture
host_tests/data/protocol_golden.bin, which protocol_test.cpp checks the encoder reproduces)."""
import os
import random
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import struct  # noqa: E402
from ballvision_link import (BallState, Decoder, Goals, LinePoints, Obstacles, Pose,  # noqa: E402
                             StatusReport, cobs_decode, cobs_encode)
from ballvision_link.protocol import (encode_frame, MSG_BALL_STATE, MSG_LINE_POINTS,  # noqa
                                      MSG_GOALS, MSG_OBSTACLES, MSG_POSE)

FIXTURE = os.path.join(os.path.dirname(__file__), "..", "..", "..", "host_tests", "data",
                       "protocol_golden.bin")


class ProtocolTest(unittest.TestCase):
    def test_decodes_cpp_stream(self):
        data = open(FIXTURE, "rb").read()
        msgs = list(Decoder().feed(data))
        self.assertEqual(len(msgs), 6)
        ball, status = msgs[:2]
        self.assertIsInstance(ball, BallState)
        self.assertEqual(ball.seq, 41)
        self.assertEqual(ball.t_us, 1000000)
        self.assertEqual(ball.mode, "rolling")
        self.assertAlmostEqual(ball.y, 3.5)
        self.assertAlmostEqual(ball.omni_u, 100.5)
        self.assertEqual(ball.t_bounce_us, 1250000)
        self.assertEqual(ball.predict_ahead_us, 200000)
        self.assertEqual((ball.px, ball.py), (0.0625, 3.625))
        self.assertEqual((ball.sigma_x, ball.sigma_y, ball.sigma_z), (0.013, 0.036, 0.002))
        self.assertEqual((ball.psigma_x, ball.psigma_y, ball.psigma_z), (0.041, 0.091, 0.021))
        self.assertIsInstance(status, StatusReport)
        self.assertEqual(status.frames_processed, 30)
        self.assertAlmostEqual(status.frame_rate_hz, 30.0)
        self.assertEqual(status.calibration_id, 0x1234)
        self.assertEqual((status.rx_overruns, status.rx_ring_full, status.rx_line_errors),
                         (1, 2, 3))
        self.assertEqual((status.feature_packets_dropped, status.line_points_unsent), (4, 5))

    def test_decodes_cpp_field_packets(self):
        # protocol_test.cpp: SamplePose(), SampleFeatures(3 lines, 2 obstacles) at t = 1 s.
        pose, obstacles, lines, goals = list(Decoder().feed(open(FIXTURE, "rb").read()))[2:]
        self.assertIsInstance(pose, Pose)
        self.assertEqual((pose.seq, pose.t_us, pose.state), (43, 1000000, "tracking"))
        self.assertEqual((pose.x, pose.y, pose.heading), (1.5, -2.25, 0.5))
        self.assertEqual((pose.sigma_x, pose.sigma_y, pose.sigma_heading), (0.0625, 0.125,
                                                                            0.03125))
        self.assertEqual((pose.quality, pose.points_used, pose.inliers), (0.75, 40, 33))
        self.assertTrue(pose.ambiguous)
        self.assertFalse(pose.hint_rejected)
        self.assertIsInstance(obstacles, Obstacles)
        self.assertEqual((obstacles.seq, obstacles.found), (44, 2))
        self.assertEqual(obstacles.obstacles, [(1.0, -0.5, 0.25), (2.0, -1.0, 0.25)])
        self.assertIsInstance(lines, LinePoints)
        self.assertEqual((lines.seq, lines.found), (45, 3))
        self.assertEqual(lines.points, [(-1.0, 2.0), (-0.75, 1.875), (-0.5, 1.75)])
        self.assertIsInstance(goals, Goals)
        self.assertEqual((goals.seq, goals.found), (46, 1))
        self.assertEqual(goals.goals, [(0.25, 4.5, 1.515, 0.25, 4, 1, 1, True)])

    def test_field_packets_round_trip_and_bad_payloads(self):
        dec = Decoder()
        pose = struct.pack("<QBBHH7f", 5, 3, 4, 10, 8, 1, 2, 0.5, 0.1, 0.1, 0.01, 0.5)
        lines = struct.pack("<QHBB", 6, 70, 2, 0) + struct.pack("<4h", 1000, -2000, 32767, -32768)
        obst = struct.pack("<QBB", 7, 1, 1) + struct.pack("<hhH", -1500, 500, 300)
        goal = struct.pack("<QBB", 8, 1, 1) + struct.pack("<hhhHBBbB", 4000, -200, -50, 240, 5, 0,
                                                          -1, 0)
        msgs = list(dec.feed(encode_frame(MSG_POSE, 1, pose) + encode_frame(MSG_LINE_POINTS, 2, lines)
                             + encode_frame(MSG_OBSTACLES, 3, obst) + encode_frame(MSG_GOALS, 4, goal)))
        self.assertEqual(len(msgs), 4)
        self.assertEqual(msgs[3].goals, [(4.0, -0.2, -0.05, 0.24, 5, 0, -1, False)])
        self.assertEqual((msgs[0].state, msgs[0].usable, msgs[0].ambiguous), ("coasting", True,
                                                                               False))
        self.assertEqual(msgs[1].points, [(1.0, -2.0), (32.767, -32.768)])
        self.assertEqual(msgs[1].found, 70)
        self.assertEqual(msgs[2].obstacles, [(-1.5, 0.5, 0.3)])
        nan = float("nan")
        bad = [
            (MSG_POSE, pose[:-1]),  # truncated
            (MSG_POSE, struct.pack("<QBBHH7f", 5, 4, 0, 1, 1, 0, 0, 0, 0, 0, 0, 0)),  # state
            (MSG_POSE, struct.pack("<QBBHH7f", 5, 2, 4, 1, 1, nan, 0, 0, 0, 0, 0, 0)),  # NaN
            (MSG_POSE, struct.pack("<QBBHH7f", 5, 2, 0, 1, 2, 0, 0, 0, 0, 0, 0, 0)),  # inliers
            (MSG_LINE_POINTS, lines[:-2]),  # truncated
            (MSG_LINE_POINTS, struct.pack("<QHBB", 6, 1, 2, 0) + lines[12:]),  # count > found
            (MSG_LINE_POINTS, struct.pack("<QHBB", 6, 300, 65, 0) + b"\x01" * 260),  # > 64
            (MSG_OBSTACLES, obst + b"\x00"),  # oversize
            (MSG_OBSTACLES, struct.pack("<QBB", 7, 40, 17) + b"\x01" * 102),  # > 16
            (MSG_GOALS, goal[:-1]),  # truncated
            (MSG_GOALS, struct.pack("<QBB", 8, 3, 3) + goal[10:] * 3),  # > 2
            (MSG_GOALS, goal[:10] + struct.pack("<hhhHBBbB", 0, 0, 3200, 0, 1, 0, 0, 0)),  # > pi
            (MSG_GOALS, goal[:10] + struct.pack("<hhhHBBbB", 0, 0, 0, 0, 1, 2, 0, 0)),  # posts
            (MSG_GOALS, goal[:10] + struct.pack("<hhhHBBbB", 0, 0, 0, 0, 1, 0, 2, 0)),  # which
            (MSG_GOALS, goal[:10] + struct.pack("<hhhHBBbB", 0, 0, 0, 0, 1, 0, 0, 4)),  # flag
        ]
        before = dec.errors["payload"]
        self.assertEqual(list(dec.feed(b"".join(encode_frame(t, 9, p) for t, p in bad))), [])
        self.assertEqual(dec.errors["payload"] - before, len(bad))

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


class ReadBackTest(unittest.TestCase):
    """The read-back command and its BlobData answer, laid out as core/protocol/link.h says."""
    def test_read_blob_and_blob_data(self):
        from ballvision_link import commands
        from ballvision_link.protocol import MSG_BLOB_DATA
        frame = commands.read_blob(5, commands.TARGET_LUT, 1024, 512)
        msgs = Decoder().feed(frame)
        self.assertEqual(msgs, [(commands.READ_BLOB, 5, struct.pack("<BIH", 2, 1024, 512))])
        with self.assertRaises(ValueError):
            commands.read_blob(6, 4, 0)
        with self.assertRaises(ValueError):
            commands.read_blob(6, 2, 0, 513)
        data = bytes(range(16))
        ok = struct.pack("<IBIII", 41, 2, 65552, 0xA1B2C3D4, 65536) + data
        (m,) = Decoder().feed(encode_frame(MSG_BLOB_DATA, 9, ok))
        self.assertEqual((m.seq, m.cmd_seq, m.target, m.total_len, m.blob_crc32, m.offset, m.data),
                         (9, 41, 2, 65552, 0xA1B2C3D4, 65536, data))
        for bad in (ok + b"\0",  # past the blob's end
                    ok[:4] + b"\4" + ok[5:],  # unknown target
                    ok[:17]):  # no data
            with self.subTest(bad=bad[:17].hex()):
                dec = Decoder()
                self.assertEqual(dec.feed(encode_frame(MSG_BLOB_DATA, 9, bad)), [])
                self.assertEqual(dec.errors["payload"], 1)


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

    def test_save_correction_is_parameter_22_set_to_one(self):
        from ballvision_link import commands
        msgs = list(Decoder().feed(commands.save_correction(7)))
        self.assertEqual(len(msgs), 1)
        self.assertEqual(msgs[0][0], 0x21)
        self.assertEqual(msgs[0][1], 7)
        self.assertEqual(struct.unpack("<Hf", msgs[0][2]), (22, 1.0))

    def test_pose_hint_commands(self):
        from ballvision_link import commands
        frames = [commands.set_field_half(1, -1), commands.odometry(2, 0.1, 0.0, -0.5),
                  commands.set_pose(3, 1.0, -2.0, 0.5), commands.set_pose(4, 0, 0, 0, known=False)]
        msgs = list(Decoder().feed(b"".join(frames)))
        self.assertEqual([m[0] for m in msgs], [0x25, 0x26, 0x27, 0x27])
        self.assertEqual(msgs[0][2], b"\xff")
        self.assertEqual(struct.unpack("<3f", msgs[1][2]), (struct.unpack("<f", struct.pack(
            "<f", 0.1))[0], 0.0, -0.5))
        self.assertEqual(struct.unpack("<B3f", msgs[2][2]), (1, 1.0, -2.0, 0.5))
        self.assertEqual(msgs[3][2][0], 0)
        with self.assertRaises(ValueError):
            commands.set_field_half(5, 2)
