"""The studio's server without a browser: captured pairs into a sequence, the HTTP API's answers
to bad requests, a folder that is not a sequence, a link that cannot be opened."""
import json
import os
import sys
import tempfile
import threading
import time
import unittest
import urllib.error
import urllib.request
from http.server import ThreadingHTTPServer
from types import SimpleNamespace

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
from ballvision_link import studio  # noqa: E402
from ballvision_link.protocol import CaptureChunk, CaptureEnd, CaptureFrame  # noqa: E402
from ballvision_link.studio_capture import CaptureWriter, upsample  # noqa: E402

CALIB = os.path.join(HERE, "../../../host_tests/data/reference_rig_calib.json")


def frame(pair, mode=2, cameras=3, nbytes=160 * 120 * 2):
    return CaptureFrame(0, 1, pair, 2, mode, cameras, 160, 120, 1000 * pair, 0, 0, 50 + pair,
                        50 + pair, nbytes)


class CaptureWriterTest(unittest.TestCase):
    def test_quarter_upsample(self):
        img = bytes((i * 7) % 256 for i in range(160 * 120 * 2))
        big = upsample(img, 2)
        self.assertEqual(len(big), 640 * 480 * 2)
        # pixel (x, y) of the big image is source pixel (x // 4, y // 4): Y, and its pair's U, V
        for x, y in ((0, 0), (5, 9), (639, 479), (322, 201)):
            sx, sy = x // 4, y // 4
            src_y = img[(sy * 160 + sx) * 2]
            self.assertEqual(big[(y * 640 + x) * 2], src_y)
            pair = (sy * 160 + (sx & ~1)) * 2
            chroma = img[pair + 1] if x % 2 == 0 else img[pair + 3]
            self.assertEqual(big[(y * 640 + x) * 2 + 1], chroma)

    def test_pairs_written_and_a_gap_breaks_one(self):
        with tempfile.TemporaryDirectory() as tmp:
            w = CaptureWriter(os.path.join(tmp, "cap"), 2, 2)
            n = 160 * 120 * 2
            self.assertEqual(w.feed(frame(0)), (False, None))
            for cam in (0, 1):
                for off in range(0, n, 512):
                    w.feed(CaptureChunk(0, 1, 0, cam, off, bytes(min(512, n - off))))
            w.feed(frame(1))
            w.feed(CaptureChunk(0, 1, 1, 0, 0, bytes(512)))
            w.feed(CaptureChunk(0, 1, 1, 0, 1024, bytes(512)))  # 512..1023 lost
            done, text = w.feed(CaptureEnd(0, 1, 2, 2, "complete"))
            self.assertTrue(done)
            self.assertIn("1 pair(s) written", text)
            self.assertIn("1 broken", text)
            with open(os.path.join(tmp, "cap", "frames.csv")) as f:
                rows = f.read().splitlines()
            self.assertEqual(rows, ["index,t_us,omni_file,persp_file",
                                    "50,0,omni/000000.yuyv,persp/000000.yuyv"])
            self.assertEqual(os.path.getsize(os.path.join(tmp, "cap", "omni/000000.yuyv")),
                             640 * 480 * 2)

    def test_nothing_complete_is_said(self):
        with tempfile.TemporaryDirectory() as tmp:
            w = CaptureWriter(os.path.join(tmp, "cap"), 1, 2)
            w.feed(frame(0))
            text = w.finish("cut off: the link ended")
            self.assertIn("no complete pair", text)
            self.assertFalse(os.path.exists(os.path.join(tmp, "cap", "frames.csv")))


class ServerTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        not_seq = os.path.join(self.tmp.name, "not_a_sequence")
        os.mkdir(not_seq)
        a = SimpleNamespace(source=not_seq, calib=CALIB, lut=None, seq=None,
                            ballvision="/nonexistent", work=os.path.join(self.tmp.name, "w"),
                            baud=921600)
        studio.Handler.studio = studio.Studio(a)
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), studio.Handler)
        threading.Thread(target=self.httpd.serve_forever, daemon=True).start()
        self.url = f"http://127.0.0.1:{self.httpd.server_address[1]}"

    def tearDown(self):
        self.httpd.shutdown()
        self.httpd.server_close()
        self.tmp.cleanup()

    def get(self, path):
        try:
            with urllib.request.urlopen(self.url + path, timeout=5) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def post(self, path, body):
        req = urllib.request.Request(self.url + path, data=body, method="POST",
                                     headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=5) as r:
                return r.status, json.loads(r.read())
        except urllib.error.HTTPError as e:
            return e.code, json.loads(e.read())

    def test_page_and_assets(self):
        code, body = self.get("/")
        self.assertEqual(code, 200)
        self.assertIn(b"ballvision studio", body)
        for name in ("studio.js", "studio.css"):
            self.assertEqual(self.get("/assets/" + name)[0], 200)
        self.assertEqual(self.get("/assets/..%2Fstudio.py")[0], 404)
        self.assertEqual(self.get("/assets/../studio.py")[0], 404)
        self.assertNotIn(b"http://", self.get("/assets/studio.js")[1])  # nothing from outside
        self.assertNotIn(b"https://", self.get("/")[1])

    def test_not_a_sequence_is_named(self):
        code, body = self.get("/api/state")
        self.assertEqual(code, 200)
        s = json.loads(body)["sequence"]
        self.assertIn("is not a captured sequence: it has no frames.csv", s["error"])
        self.assertEqual(s["frames"], [])
        code, r = self.post("/api/open", json.dumps({"path": "/no/such/dir"}).encode())
        self.assertFalse(r["ok"])
        self.assertIn("/no/such/dir: no such folder", r["message"])

    def test_bad_requests(self):
        self.assertEqual(self.post("/api/teach", b"not json")[0], 400)
        self.assertEqual(self.post("/api/teach", b"[1, 2]")[0], 400)
        code, r = self.post("/api/teach", json.dumps({"camera": "side", "index": 0, "u": 1,
                                                      "v": 2}).encode())
        self.assertFalse(r["ok"])
        self.assertIn("camera must be omni or persp", r["message"])
        code, r = self.post("/api/teach", json.dumps({"camera": "persp"}).encode())
        self.assertFalse(r["ok"])
        self.assertIn("bad request", r["message"])
        self.assertEqual(self.get("/api/frame?cam=omni&i=x&gen=1")[0], 400)
        self.assertEqual(self.get("/api/frame?cam=omni&i=3&gen=1")[0], 404)
        self.assertEqual(self.get("/api/lut")[0], 404)
        code, r = self.post("/api/upload", b"{}")
        self.assertIn("nothing to upload", r["message"])
        code, r = self.post("/api/capture", b"{}")
        self.assertIn("no coprocessor connected", r["message"])
        self.assertEqual(self.post("/api/nothing", b"{}")[0], 404)


class LiveLinkTest(unittest.TestCase):
    def test_a_port_that_is_not_there(self):
        with tempfile.TemporaryDirectory() as tmp:
            live = studio.LiveLink("tcp:127.0.0.1:1", 921600, tmp)
            deadline = time.monotonic() + 5
            while live.error is None and time.monotonic() < deadline:
                time.sleep(0.05)
            s = live.summary()
            live.stop = True
            self.assertFalse(s["connected"])
            self.assertIn("cannot open tcp:127.0.0.1:1", s["error"])
            self.assertIn("not sent", live.command(b"", 1, timeout=0.2))


if __name__ == "__main__":
    unittest.main()
