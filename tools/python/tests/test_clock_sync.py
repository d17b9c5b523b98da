"""The Python clock-sync estimator (ballvision_link.clock_sync) on a simulated link, and the
clock-sync / capture messages of the Python decoder and command encoder."""
import math
import os
import random
import struct
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from ballvision_link import commands  # noqa: E402
from ballvision_link.clock_sync import (ACCEPTED, DUPLICATE, HELD, INCONSISTENT,  # noqa: E402
                                        MISMATCH, RESTARTED, UNKNOWN_ID, ClockSync,
                                        wire_frame_bytes)
from ballvision_link.protocol import (CaptureChunk, CaptureEnd, CaptureFrame,  # noqa: E402
                                      ClockSyncReply, Decoder, encode_frame)

BYTE_US = 10.0 / 921600.0 * 1e6


class SimLink:
    """True host time t (µs); device clock dev0 + t * (1 + ppm); delays beyond the wire time."""

    def __init__(self, ppm=50.0, dev0=4e6):
        self.ppm, self.dev0, self.host0 = ppm, dev0, 1_700_000_000_000_000

    def dev(self, t):
        return self.dev0 + t * (1.0 + self.ppm * 1e-6)

    def exchange(self, sync, rid, t, out, back, hold=0.0):
        t1 = self.host0 + int(t)
        sync.request_sent(rid, t1)
        arrive = t + out + BYTE_US * wire_frame_bytes(12)
        reply = ClockSyncReply(0, rid, t1, int(self.dev(arrive)), int(self.dev(arrive + 300)))
        t4 = self.host0 + int(arrive + 300 + hold + BYTE_US * wire_frame_bytes(28) + back)
        return reply, t4

    def error(self, sync, t):
        d = self.dev(t)
        return sync.to_host_time(int(d)) + (d - math.floor(d)) - (self.host0 + t)


class ClockSyncTest(unittest.TestCase):
    def test_symmetric_delays_give_offset_and_drift(self):
        link, s = SimLink(), ClockSync()
        for i in range(100):
            self.assertEqual(s.reply(*link.exchange(s, i, i * 1e5, 200, 200)), ACCEPTED)
        self.assertLess(abs(link.error(s, 10e6)), 2.0)
        self.assertAlmostEqual(s.drift_ppm, -49.9975, delta=0.3)

    def test_minimum_delay_exchanges_decide(self):
        link, s, rng = SimLink(), ClockSync(), random.Random(5)
        naive = []
        for i in range(600):
            back = 150 + rng.expovariate(1 / 2000.0)
            hold = rng.random() * 10000 if rng.random() < 0.3 else 0.0
            self.assertNotEqual(s.reply(*link.exchange(s, i, i * 1e5, 150, back, hold)), RESTARTED)
            naive.append((back + hold - 150) / 2)
        err = link.error(s, 60e6)
        self.assertLess(abs(err), 60.0)
        self.assertGreater(sum(naive) / len(naive), 10 * abs(err))
        self.assertAlmostEqual(s.drift_ppm, -49.9975, delta=2.0)

    def test_duplicate_unknown_mismatch_and_out_of_order(self):
        link, s = SimLink(), ClockSync()
        a, t4a = link.exchange(s, 1, 0, 200, 200)
        b, t4b = link.exchange(s, 2, 1e5, 200, 200)
        self.assertEqual(s.reply(b, t4b), ACCEPTED)
        self.assertEqual(s.reply(a, t4a + 100000), ACCEPTED)  # out of order, late
        self.assertEqual(s.reply(b, t4b + 5000), DUPLICATE)
        self.assertEqual(s.reply(ClockSyncReply(0, 77, b.t1_host_us, b.t2_rx_us, b.t3_tx_us),
                                 t4b), UNKNOWN_ID)
        c, t4c = link.exchange(s, 3, 2e5, 200, 200)
        self.assertEqual(s.reply(ClockSyncReply(0, 3, c.t1_host_us + 1, c.t2_rx_us, c.t3_tx_us),
                                 t4c), MISMATCH)
        self.assertEqual(s.reply(c, c.t1_host_us - 1), INCONSISTENT)
        self.assertEqual(s.reply(c, t4c), ACCEPTED)
        self.assertLess(abs(link.error(s, 2e5)), 15.0)

    def test_reset_restarts(self):
        link, s = SimLink(), ClockSync()
        for i in range(50):
            self.assertEqual(s.reply(*link.exchange(s, i, i * 1e5, 200, 200)), ACCEPTED)
        link.dev0 = 1000 - 5e6 * (1 + link.ppm * 1e-6)
        link.ppm = 20.0
        verdicts = [s.reply(*link.exchange(s, i, i * 1e5, 200, 200)) for i in range(50, 100)]
        self.assertEqual(verdicts[:2], [HELD, RESTARTED])
        self.assertEqual(set(verdicts[2:]), {ACCEPTED})
        self.assertEqual(s.restarts, 1)
        self.assertLess(abs(link.error(s, 10e6)), 3.0)
        self.assertAlmostEqual(s.drift_ppm, -19.9996, delta=0.5)

    def test_one_outlier_is_held_then_dropped(self):
        link, s = SimLink(), ClockSync()
        for i in range(30):
            self.assertEqual(s.reply(*link.exchange(s, i, i * 1e5, 200, 200)), ACCEPTED)
        odd, t4 = link.exchange(s, 30, 30e5, 200, 200)
        odd = ClockSyncReply(0, 30, odd.t1_host_us, odd.t2_rx_us + 20000, odd.t3_tx_us + 20000)
        self.assertEqual(s.reply(odd, t4), HELD)
        self.assertEqual(s.reply(*link.exchange(s, 31, 31e5, 200, 200)), ACCEPTED)
        self.assertEqual((s.restarts, s.counts["rejected"]), (0, 1))
        self.assertLess(abs(link.error(s, 31e5)), 3.0)

    def test_no_exchange_yet(self):
        with self.assertRaisesRegex(ValueError, "no exchange yet"):
            ClockSync().to_host_time(5)


class LinkMessagesTest(unittest.TestCase):
    def test_sync_reply_and_capture_packets_decode(self):
        stream = encode_frame(0x0A, 1, struct.pack("<IQQQ", 9, 123, 1000, 1400))
        stream += encode_frame(0x0A, 2, struct.pack("<IQQQ", 9, 123, 1400, 1000))  # t3 < t2
        stream += encode_frame(0x0B, 3, struct.pack("<HHHBBHHQQQIII", 1, 0, 2, 2, 3, 160, 120,
                                                    5, 5, 5, 7, 7, 160 * 120 * 2))
        stream += encode_frame(0x0B, 4, struct.pack("<HHHBBHHQQQIII", 1, 0, 2, 2, 3, 320, 240,
                                                    5, 5, 5, 7, 7, 320 * 240 * 2))  # size != mode
        stream += encode_frame(0x0C, 5, struct.pack("<HHBBI", 1, 0, 1, 0, 512) + b"\x01" * 512)
        stream += encode_frame(0x0C, 6, struct.pack("<HHBBI", 1, 0, 0, 0, 614400 - 4) + b"x" * 8)
        stream += encode_frame(0x0D, 7, struct.pack("<HHHB", 1, 2, 1, 2))
        stream += encode_frame(0x0D, 8, struct.pack("<HHHB", 1, 2, 3, 0))  # sent > requested
        d = Decoder()
        msgs = d.feed(stream)
        self.assertEqual([type(m) for m in msgs],
                         [ClockSyncReply, CaptureFrame, CaptureChunk, CaptureEnd])
        self.assertEqual((msgs[0].id, msgs[0].t2_rx_us, msgs[0].t3_tx_us), (9, 1000, 1400))
        self.assertEqual((msgs[1].width, msgs[1].image_bytes), (160, 38400))
        self.assertEqual((msgs[2].camera, msgs[2].offset, len(msgs[2].data)), (1, 512, 512))
        self.assertEqual(msgs[3].reason, "camera finished")
        self.assertEqual(d.errors["payload"], 4)

    def test_capture_command_bounds(self):
        self.assertEqual(commands.capture_start(1, 100, commands.CAPTURE_QUARTER)[-1], 0)
        for bad in (0, 101):
            with self.assertRaisesRegex(ValueError, "1..100"):
                commands.capture_start(1, bad)
        frame = commands.capture_start(1, 5, commands.CAPTURE_SCANLINES, 1)
        mtype, _, payload = Decoder().feed(frame)[0]
        self.assertEqual((mtype, payload), (0x29, struct.pack("<HBB", 5, 3, 1)))
        with self.assertRaisesRegex(ValueError, "mode"):
            commands.capture_start(1, 1, 4)

    def test_scanline_capture_frame(self):
        def frame(cameras, image_bytes):
            return encode_frame(0x0B, 1, struct.pack("<HHHBBHHQQQIII", 1, 0, 1, 3, cameras, 640,
                                                     480, 5, 5, 5, 7, 7, image_bytes))
        msgs = Decoder().feed(frame(3, 16 + 3 * (15000 + 10000)))
        self.assertEqual([type(m) for m in msgs], [CaptureFrame])
        self.assertEqual((msgs[0].mode, msgs[0].width), (3, 640))
        d = Decoder()
        self.assertEqual(d.feed(frame(3, 11) + frame(1, 8 + 3 * 65536)), [])  # too few / many
        self.assertEqual(d.errors["payload"], 2)


if __name__ == "__main__":
    unittest.main()
