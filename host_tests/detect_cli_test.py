"""Issue 39's command-line cases: `ballvision detect` (its JSON, its summary), and every bad input
of detect, detect-eval and `lut teach --boxes` refused with a reason naming the file and the field,
nothing half-written, the old file kept. Small fixtures only (host_tests/data/stills).
Run by ctest:  python3 detect_cli_test.py BALLVISION"""
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import unittest
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
STILL = os.path.join(HERE, "data", "stills", "ball_200x160.jpg")
BOX = "ball_200x160.jpg 0 ball 38.15 51.82 109.16 125.14\n"
BV = None  # set from argv


def read(path, mode="rb"):
    with open(path, mode) as f:
        return f.read()


def png(path, width, height, grey=128):
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c))
    rows = b"".join(b"\x00" + bytes([grey]) * width for _ in range(height))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8,
                                                                 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


class Base(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name
        os.makedirs(self.p("img"))
        shutil.copy(STILL, self.p("img"))
        with open(self.p("boxes.txt"), "w") as f:
            f.write(BOX)

    def tearDown(self):
        self.tmp.cleanup()

    def p(self, *names):
        return os.path.join(self.d, *names)

    def bv(self, *args):
        return subprocess.run([BV, *args], capture_output=True, text=True, timeout=120)

    def refused(self, args, rc, *messages, keep=()):
        before = {k: read(k) if os.path.exists(k) else None for k in keep}
        r = self.bv(*args)
        self.assertEqual(r.returncode, rc, r.stdout + r.stderr)
        for m in messages:
            self.assertIn(m, r.stderr)
        for k, old in before.items():
            self.assertEqual(read(k) if os.path.exists(k) else None, old, k)
        self.assertEqual([f for f in os.listdir(self.d) if f.startswith(".")], [],
                         "temporary file left behind")
        return r


class Detect(Base):
    def test_json_and_summary(self):
        r = self.bv("detect", "--lut", "builtin", "--ball", "yellow", "--json", self.p("o.json"),
                    "--max-balls", "3", self.p("img"))
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(read(self.p("o.json"), "r"))
        self.assertEqual(list(doc), ["images"])
        im = doc["images"][0]
        self.assertEqual((os.path.basename(im["file"]), im["width"], im["height"]),
                         ("ball_200x160.jpg", 200, 160))
        self.assertLessEqual(len(im["balls"]), 3)
        self.assertTrue(im["balls"], "the built-in yellow model and classifier find the ball")
        b = im["balls"][0]
        self.assertEqual(sorted(b), ["r", "score", "u", "v"])
        self.assertTrue(38 <= b["u"] <= 110 and 51 <= b["v"] <= 126, b)
        self.assertIn("ball (", r.stdout)
        self.assertIn("1 images, a ball in 1", r.stdout)

    def test_annotate_and_candidates(self):
        os.makedirs(self.p("ann"))
        r = self.bv("detect", "--lut", "builtin", "--ball", "yellow", "--json", self.p("o.json"),
                    "--annotate", self.p("ann"), "--candidates", self.p("c.csv"), STILL)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(os.listdir(self.p("ann")), ["ball_200x160.jpg.png"])
        head = read(self.p("c.csv"), "r").splitlines()[0]
        self.assertTrue(head.startswith("file,u,v,r,area,chosen,refusal"), head)

    def test_annotate_directory_made_or_refused_up_front(self):
        # Made where missing (as `run --annotate` does), parents too.
        r = self.bv("detect", "--lut", "builtin", "--json", self.p("o.json"), "--annotate",
                    self.p("new", "ann"), STILL)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(os.listdir(self.p("new", "ann")), ["ball_200x160.jpg.png"])
        # A file in its way: refused before any image is read, naming it; no JSON written.
        with open(self.p("plain"), "w") as f:
            f.write("x")
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o2.json"), "--annotate",
                      self.p("plain"), STILL], 1, "cannot create the directory " + self.p("plain"))
        self.assertFalse(os.path.exists(self.p("o2.json")))

    def test_truncated_and_corrupt_jpeg(self):
        data = read(STILL)
        with open(self.p("cut.jpg"), "wb") as f:
            f.write(data[:len(data) // 2])
        with open(self.p("o.json"), "w") as f:
            f.write("old")
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"), self.p("cut.jpg")],
                     1, "cut.jpg: corrupt or truncated JPEG", "not written", keep=[self.p("o.json")])
        bad = bytearray(data)
        for i in range(len(bad) // 3, len(bad) // 3 + 400, 7):
            bad[i] ^= 0x5A
        with open(self.p("bad.jpg"), "wb") as f:
            f.write(bytes(bad))
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"), self.p("bad.jpg")],
                     1, "bad.jpg: corrupt or truncated JPEG", keep=[self.p("o.json")])

    def test_image_larger_than_the_device_frame(self):
        png(self.p("big.png"), 1300, 40)
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"), self.p("big.png")],
                     1, "big.png: image is 1300x40, larger than the largest frame the device "
                        "takes (1280x1024)")
        self.assertFalse(os.path.exists(self.p("o.json")))

    def test_not_an_image_and_a_directory_of_other_files(self):
        with open(self.p("img", "notes.txt"), "w") as f:
            f.write("hello")
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"), self.p("img")], 1,
                     "notes.txt: not an image")
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"),
                      self.p("img", "notes.txt")], 1, "notes.txt: not a JPEG or PNG image")
        os.makedirs(self.p("empty"))
        self.refused(["detect", "--lut", "builtin", "--json", self.p("o.json"), self.p("empty")],
                     1, "empty: no JPEG or PNG image in it")

    def test_classifier_blob_of_the_wrong_size_version_or_crc(self):
        good = self.p("w.bin")
        shutil.copy(os.path.join(HERE, "data", "ball_classifier", "builtin.bin"), good)
        data = read(good)
        cases = {
            "short.bin": (data[:-5], "short.bin: blob: payload truncated"),
            "crc.bin": (data[:40] + bytes([data[40] ^ 1]) + data[41:], "crc.bin: blob: CRC-32"),
            "newer.bin": (data[:6] + struct.pack("<H", 2) + data[8:],
                          "newer.bin: blob: unsupported version"),
        }
        for name, (blob, message) in cases.items():
            with open(self.p(name), "wb") as f:
                f.write(blob)
            self.refused(["detect", "--lut", "builtin", "--classifier", self.p(name), "--json",
                          self.p("o.json"), STILL], 1, message)
        r = self.bv("detect", "--lut", "builtin", "--classifier", good, "--json", self.p("o.json"),
                    STILL)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_usage(self):
        r = self.refused(["detect", "--json", self.p("o.json"), STILL], 2, "missing --lut")
        self.assertIn("usage: ballvision detect", r.stderr)
        self.refused(["detect", "--lut", "x.lut", "--ball", "yellow", "--json", self.p("o.json"),
                      STILL], 2, "--ball chooses a built-in model")
        self.refused(["detect", "--lut", "builtin", "--ball", "green", "--json", self.p("o.json"),
                      STILL], 1, "--ball: got 'green', expected red, orange or yellow")


class Boxes(Base):
    def eval_refused(self, boxes, *messages):
        with open(self.p("b.txt"), "w") as f:
            f.write(boxes)
        return self.refused(["detect-eval", "--boxes", self.p("b.txt"), "--images", self.p("img"),
                             "--protocol", "builtin"], 1, *messages)

    def test_box_outside_unknown_class_empty_file(self):
        self.eval_refused("ball_200x160.jpg 0 ball 150 100 260 150\n",
                          "b.txt:1: ball box (150, 100)-(260, 150) lies outside ball_200x160.jpg "
                          "(200x160)")
        self.eval_refused(BOX + "ball_200x160.jpg 7 referee 1 1 5 5\n",
                          "b.txt:2: unknown class '7 referee'")
        self.eval_refused(BOX + "ball_200x160.jpg 1 ball 1 1 5 5\n",
                          "b.txt:2: unknown class '1 ball'")
        self.eval_refused("# only a comment\n\n", "b.txt: no image listed (empty box file)")
        self.eval_refused("ball_200x160.jpg 0 ball 9 9 5 5\n", "b.txt:1: box has x1 < x0")
        self.eval_refused("ball_200x160.jpg 0 ball 1 2 three 4\n",
                          "b.txt:1: box corners are not numbers")

    def test_eval_scores_the_fixture(self):
        r = self.bv("detect-eval", "--boxes", self.p("boxes.txt"), "--images", self.p("img"),
                    "--protocol", "builtin", "--json", self.p("e.json"))
        self.assertEqual(r.returncode, 0, r.stderr)
        e = json.loads(read(self.p("e.json"), "r"))["builtin"]["pooled"]
        self.assertEqual((e["images"], e["countable"], e["found"], e["false_images"]),
                         (1, 1, 1, 0))

    def test_more_boxes_add_to_the_images_of_the_box_file_only(self):
        with open(self.p("more.txt"), "w") as f:
            f.write("# a second ball\nball_200x160.jpg 0 ball 150 10 170 30\n")
        r = self.bv("detect-eval", "--boxes", self.p("boxes.txt"), "--more-boxes",
                    self.p("more.txt"), "--images", self.p("img"), "--protocol", "builtin",
                    "--json", self.p("e.json"))
        self.assertEqual(r.returncode, 0, r.stderr)
        e = json.loads(read(self.p("e.json"), "r"))["builtin"]["pooled"]
        self.assertEqual((e["images"], e["found"], e["false_images"]), (1, 1, 0))
        with open(self.p("more.txt"), "w") as f:
            f.write("\nother.jpg 0 ball 1 1 9 9\n")
        self.refused(["detect-eval", "--boxes", self.p("boxes.txt"), "--more-boxes",
                      self.p("more.txt"), "--images", self.p("img"), "--protocol", "builtin"], 1,
                     "more.txt:2: image other.jpg is not in the box file it adds to")

    def test_teach_writes_the_table_and_its_profile_or_says_why_not(self):
        r = self.bv("lut", "teach", "--boxes", self.p("boxes.txt"), "--images", self.p("img"),
                    "--out", self.p("t.lut"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("no floor-ball profile: fewer than 3 whole balls", r.stdout)
        self.assertNotIn("hardly moved", r.stdout + r.stderr)
        blob = read(self.p("t.lut"))
        self.assertEqual(struct.unpack("<4sHH", blob[:8]), (b"BVB1", 2, 2))
        self.assertEqual(len(blob), 16 + 4 + 65536 + 32)

    def test_teach_refusals_keep_the_old_table(self):
        with open(self.p("t.lut"), "wb") as f:
            f.write(b"old table")
        with open(self.p("carpet.txt"), "w") as f:
            f.write("ball_200x160.jpg 0 ball 150 10 190 40\n")  # the carpet beside the ball
        self.refused(["lut", "teach", "--boxes", self.p("carpet.txt"), "--images", self.p("img"),
                      "--out", self.p("t.lut")], 1, "their colours are the field's or the lines'",
                     "not written", keep=[self.p("t.lut")])
        with open(self.p("none.txt"), "w") as f:
            f.write("ball_200x160.jpg 1 obstacle 1 1 20 20\n")
        self.refused(["lut", "teach", "--boxes", self.p("none.txt"), "--images", self.p("img"),
                      "--out", self.p("t.lut")], 1, "none.txt: no ball box among the 1 images",
                     keep=[self.p("t.lut")])
        with open(self.p("out.txt"), "w") as f:
            f.write("ball_200x160.jpg 0 ball 190 150 230 190\n")
        self.refused(["lut", "teach", "--boxes", self.p("out.txt"), "--images", self.p("img"),
                      "--out", self.p("t.lut")], 1, "out.txt:1: ball box", "lies outside",
                     keep=[self.p("t.lut")])

    def test_split_means_the_same_before_or_after_the_boxes(self):
        shutil.copy(STILL, self.p("img", "second.jpg"))
        with open(self.p("two.txt"), "w") as f:
            f.write(BOX + "second.jpg 0 ball 38.15 51.82 109.16 125.14\n")
        outs = []
        for i, order in enumerate((["--split", "odd", "--boxes", self.p("two.txt"), "--images",
                                    self.p("img")],
                                   ["--boxes", self.p("two.txt"), "--images", self.p("img"),
                                    "--split", "odd"])):
            out = self.p("t%d.lut" % i)
            r = self.bv("lut", "train", "--out", out, *order)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("(odd): 1 images", r.stdout)
            outs.append(read(out))
        self.assertEqual(outs[0], outs[1])

    def test_a_mistake_prints_that_commands_usage_only(self):
        for sub, usage in (("teach", "usage: ballvision lut teach"),
                           ("train", "usage: ballvision lut train"),
                           ("eval", "usage: ballvision lut eval")):
            r = self.bv("lut", sub, "--bogus")
            self.assertEqual(r.returncode, 2)
            self.assertIn(usage, r.stderr)
            others = {"teach", "train", "eval", "show"} - {sub}
            for o in others:
                self.assertNotIn("ballvision lut %s " % o, r.stderr, sub)


if __name__ == "__main__":
    BV = os.path.abspath(sys.argv.pop(1))
    unittest.main()
