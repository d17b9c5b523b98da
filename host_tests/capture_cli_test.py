#!/usr/bin/env python3
"""`ballvision capture` on recorded streams written with the Python encoder: a quarter-size
capture scaled back to 640x480, a lost chunk (that pair dropped, the others kept, exit 1),
and refused options.   capture_cli_test.py BALLVISION"""
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools", "python"))
from ballvision_link.protocol import Decoder, encode_frame  # noqa: E402

BV = sys.argv.pop(1) if len(sys.argv) > 1 else "build/host/tools/ballvision"
W, H = 160, 120  # quarter
CALIB = os.path.join(os.path.dirname(__file__), "data", "reference_rig_calib.json")


def image(pair, camera):
    return bytes(((i * 7 + pair * 13 + camera * 101) >> 2) & 0xFF for i in range(W * H * 2))


def stream(pairs, drop_chunk=None, end=True):
    out, seq = b"", 100
    for p in range(pairs):
        out += encode_frame(0x0B, seq, struct.pack("<HHHBBHHQQQIII", 1, p, pairs, 2, 3, W, H,
                                                  1000 + p * 33333, 1000 + p * 33333,
                                                  1000 + p * 33333, 40 + p, 40 + p, W * H * 2))
        seq += 1
        for cam in (0, 1):
            img = image(p, cam)
            for off in range(0, len(img), 512):
                if (p, cam, off) != drop_chunk:
                    out += encode_frame(0x0C, seq, struct.pack("<HHBBI", 1, p, cam, 0, off) +
                                        img[off:off + 512])
                seq += 1
        out += encode_frame(0x01, seq, bytes(92))  # a ball state in between: ignored
        seq += 1
    if end:
        out += encode_frame(0x0D, seq, struct.pack("<HHHB", 1, pairs, pairs, 0))
    return out


def run(*args):
    return subprocess.run([BV, "capture", *args], capture_output=True, text=True)


class FakeCoprocessor(threading.Thread):
    """A TCP peer that waits for one command frame, then sends `answer(request)` and keeps the
    connection open (the tool must stop at the capture end packet, not at end of file)."""

    def __init__(self, answer):
        super().__init__(daemon=True)
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.answer, self.request = answer, None

    def run(self):
        conn, _ = self.server.accept()
        self.server.close()
        dec = Decoder()
        while self.request is None:
            data = conn.recv(4096)
            if not data:
                return
            for msg in dec.feed(data):
                self.request = msg
        conn.sendall(self.answer(self.request))
        conn.recv(1)  # until the tool closes its end
        conn.close()


class CaptureCli(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def write(self, data):
        path = os.path.join(self.dir, "uart.bin")
        with open(path, "wb") as f:
            f.write(data)
        return path

    def test_quarter_capture_is_scaled_back_to_640x480(self):
        out = os.path.join(self.dir, "seq")
        r = run(self.write(stream(2)), "--out", out)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        with open(os.path.join(out, "frames.csv")) as f:
            rows = f.read().splitlines()
        self.assertEqual(rows, ["index,t_us,omni_file,persp_file",
                                "40,1000,omni_40.yuyv,persp_40.yuyv",
                                "41,34333,omni_41.yuyv,persp_41.yuyv"])
        with open(os.path.join(out, "persp_41.yuyv"), "rb") as f:
            big = f.read()
        self.assertEqual(len(big), 640 * 480 * 2)
        small = image(1, 1)
        for y, x in ((0, 0), (5, 9), (479, 639), (200, 321)):
            sx, sy = x // 4, y // 4
            self.assertEqual(big[(y * 640 + x) * 2], small[(sy * W + sx) * 2], (x, y))
            # U (even x) or V (odd x): the decimated macropixel's
            self.assertEqual(big[(y * 640 + x) * 2 + 1],
                             small[(sy * W + sx - sx % 2) * 2 + (1 if x % 2 == 0 else 3)], (x, y))
        with open(os.path.join(out, "capture.json")) as f:
            meta = f.read()
        self.assertIn('"complete": true', meta)
        self.assertIn('"upsampled_to_640x480": true', meta)

    def test_lost_chunk_drops_that_pair_only(self):
        out = os.path.join(self.dir, "seq")
        r = run(self.write(stream(3, drop_chunk=(1, 0, 1024))), "--out", out)
        self.assertEqual(r.returncode, 1)
        self.assertIn("pair 1 of capture 1 incomplete: chunk at byte 1536 of camera 0, "
                      "expected 1024 (packets lost)", r.stderr)
        with open(os.path.join(out, "frames.csv")) as f:
            self.assertEqual([row.split(",")[0] for row in f.read().splitlines()[1:]],
                             ["40", "42"])
        with open(os.path.join(out, "capture.json")) as f:
            meta = f.read()
        self.assertIn('"note": "1 pair(s) lost in transmission"', meta)
        self.assertIn('"complete": false', meta)

    def test_live_request_over_tcp(self):
        peer = FakeCoprocessor(lambda req: stream(2))
        peer.start()
        out = os.path.join(self.dir, "live")
        r = run(f"tcp:127.0.0.1:{peer.port}", "--out", out, "--pairs", "2", "--mode", "quarter",
                "--seconds", "20")
        peer.join(5)
        self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
        mtype, seq, payload = peer.request  # what the tool sent: count 2, quarter, both cameras
        self.assertEqual((mtype, seq, payload), (0x29, 1, struct.pack("<HBB", 2, 2, 3)))
        self.assertIn("pairs_written=2 of 2", r.stdout)

    def test_live_request_refused(self):
        busy = encode_frame(0x11, 9, struct.pack("<BIBI", 0x29, 1, 12, 0))
        peer = FakeCoprocessor(lambda req: busy)
        peer.start()
        r = run(f"tcp:127.0.0.1:{peer.port}", "--out", os.path.join(self.dir, "x"),
                "--seconds", "20")
        peer.join(5)
        self.assertEqual(r.returncode, 1)
        self.assertIn("the coprocessor refused the request: busy: a capture is running", r.stderr)
        with open(os.path.join(self.dir, "x", "capture.json")) as f:
            self.assertIn('"note": "refused by the coprocessor: busy: a capture is running"',
                          f.read())

    def test_refused_options_and_outputs(self):
        src = self.write(stream(1))
        for args, msg in ((["--pairs", "0"], "--pairs"), (["--pairs", "101"], "--pairs"),
                          (["--mode", "eighth"], "--mode: got 'eighth', expected full, half, "
                                                  "quarter or scanlines"),
                          (["--mode", "scanlines"], "--mode scanlines needs --calib FILE"),
                          (["--cameras", "all"], "--cameras: got 'all'")):
            r = run(src, "--out", os.path.join(self.dir, "x"), *args)
            self.assertEqual(r.returncode, 2, args)
            self.assertIn(msg, r.stderr)
        r = run(src)
        self.assertEqual(r.returncode, 2)
        self.assertTrue(r.stderr.startswith("ballvision capture: missing --out\n"), r.stderr)
        self.assertIn("usage: ballvision capture", r.stderr)
        out = os.path.join(self.dir, "seq")
        self.assertEqual(run(src, "--out", out).returncode, 0)
        r = run(src, "--out", out)  # would overwrite a sequence
        self.assertEqual(r.returncode, 1)
        self.assertIn("already holds a sequence (frames.csv)", r.stderr)
        r = run(src, "--out", src)
        self.assertEqual(r.returncode, 1)
        self.assertIn("exists and is not a directory", r.stderr)

    def test_scanline_stream_of_another_table_is_refused(self):
        # A scanline stream of 5 omni samples: the reference calibration's table has thousands.
        n = 5
        body = struct.pack("<II", n, 0x12345678) + bytes(range(3 * n))
        data = encode_frame(0x0B, 1, struct.pack("<HHHBBHHQQQIII", 1, 0, 1, 3, 1, 640, 480,
                                                 1000, 1000, 0, 40, 0, len(body)))
        data += encode_frame(0x0C, 2, struct.pack("<HHBBI", 1, 0, 0, 0, 0) + body)
        data += encode_frame(0x0D, 3, struct.pack("<HHHB", 1, 1, 1, 0))
        src = self.write(data)
        r = run(src, "--out", os.path.join(self.dir, "nocal"))
        self.assertEqual(r.returncode, 1)
        self.assertIn("a scanline capture needs --calib FILE", r.stderr)
        out = os.path.join(self.dir, "seq")
        r = run(src, "--out", out, "--calib", CALIB)
        self.assertEqual(r.returncode, 1, r.stdout + r.stderr)
        self.assertRegex(r.stderr, r"omni: the device sent 5 scanline samples, the table built "
                                   r"from the calibration has \d{4,}")
        with open(os.path.join(out, "capture.json")) as f:
            meta = f.read()
        self.assertIn('"mode": "scanlines"', meta)
        self.assertIn('"note": "refused: omni: the device sent 5 scanline samples', meta)
        self.assertIn('NOT expected to give the device', meta)
        with open(os.path.join(out, "frames.csv")) as f:
            self.assertEqual(f.read().splitlines(), ["index,t_us,omni_file,persp_file"])


if __name__ == "__main__":
    unittest.main()
