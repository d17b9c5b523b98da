"""Hostile-input tests of the `ballvision` CLI and the Python listener (issue 15), run by ctest
as hostile_cli_test with the binary's path:  python3 hostile_cli_test.py BALLVISION
Each case asserts the exit code, the exact refusal and that no output file changed."""
import json
import os
import resource
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
REF = os.path.join(HERE, "data", "reference_rig_calib.json")
GOLDEN = os.path.join(HERE, "data", "protocol_golden.bin")
PYLINK = os.path.join(HERE, "..", "tools", "python")
BOUNCE = os.path.join(HERE, "..", "..", "shared", "data", "sim", "bounce")
BV = None  # set from argv


def read(path, mode="r"):
    with open(path, mode) as f:
        return f.read()


def write(path, data):
    with open(path, "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)


def png(path, width, height):
    """A grey 8-bit PNG (no dependencies)."""
    def chunk(kind, data):
        c = kind + data
        return struct.pack(">I", len(data)) + c + struct.pack(">I", zlib.crc32(c))
    rows = b"".join(b"\x00" + bytes([128]) * width for _ in range(height))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8,
                                                                 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


class Base(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.d = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def path(self, name):
        return os.path.join(self.d, name)

    def bv(self, *args, **kw):
        return subprocess.run([BV, *args], capture_output=True, text=True, timeout=120, **kw)

    def refused(self, args, rc, message, keep=()):
        """Runs, asserts exit code and message, and that the files in `keep` are unchanged."""
        before = {p: read(p, "rb") if os.path.exists(p) else None for p in keep}
        r = self.bv(*args)
        self.assertEqual(r.returncode, rc, r.stderr)
        self.assertIn(message, r.stderr)
        for p, old in before.items():
            self.assertEqual(read(p, "rb") if os.path.exists(p) else None, old, p)
        self.assertEqual([f for f in os.listdir(self.d) if f.startswith(".")], [],
                         "temporary file left behind")
        return r

    def seq(self, truth=None, persp_size=(640, 480)):
        os.makedirs(self.path("s"), exist_ok=True)
        png(self.path("s/p0.png"), *persp_size)
        write(self.path("s/frames.csv"), "index,t_us,omni_file,persp_file\n"
                                                   "0,0,,p0.png\n")
        if truth is not None:
            write(self.path("s/truth.csv"), truth)
        return self.path("s")

    def calib(self, edit):
        d = json.loads(read(REF))
        edit(d)
        p = self.path("c.json")
        with open(p, "w") as f:
            json.dump(d, f)
        return p


class CalibrationJson(Base):
    def test_type_confusion_in_valid(self):
        for v, shown in ((1, "1 (integer)"), ("yes", '"yes" (string)'), (None, "null (null)")):
            p = self.calib(lambda d: d["persp"].__setitem__("valid", v))
            for cmd in (["calib", "show", p], ["run", self.seq(), "--calib", p]):
                self.refused(cmd, 1, f"c.json: persp.valid: got {shown}, expected true or false")

    def test_ids_not_converted(self):
        out = self.path("out.json")
        write(out, "OLD")
        for v in (2**64, 1.5, -1, "7"):
            p = self.calib(lambda d: d.__setitem__("lut_id", v))
            r = self.refused(["calib", "to-json", p, out], 1, "c.json: lut_id: got ", [out])
            self.assertIn("expected an integer in [0, 4294967295]", r.stderr)

    def test_unknown_version_format_model(self):
        cases = [(lambda d: d.__setitem__("version", 5), "version: got 5 (integer), expected "
                  "an integer in [1, 4]"),
                 (lambda d: d["omni"].__setitem__("self_mask", {
                     "inner_radius_px": 54, "outer_radius_px": 219, "body_px": [50] * 64,
                     "sectors": [[10, 40], [100, 40]]}),
                  "self-mask: sectors cover more than 120 deg"),
                 (lambda d: d.__setitem__("field", {"length": "18"}),
                  'field.length: got "18" (string), expected a number in [0.5, 40.0]'),
                 (lambda d: d.__setitem__("field", {"goal_area_width": 7.0}),
                  "field.goal_area_width: not positive or wider than the penalty area"),
                 (lambda d: d.__setitem__("format", "other"), 'format: got "other" (string), '
                  'expected one of "ballvision-calibration"'),
                 (lambda d: d.pop("format"), "format: missing"),
                 (lambda d: d["persp"].__setitem__("model", "fisheye"),
                  'persp.model: got "fisheye" (string), expected one of "zhang_k1k2"'),
                 (lambda d: d["omni"].__setitem__("image_angle_sign", 0.5),
                  "omni.image_angle_sign: got 0.5 (number), expected an integer in [-1, 1]"),
                 (lambda d: d["omni"]["support_px"][3].__setitem__(4, "x"),
                  'omni.support_px[3][4]: got "x" (string), expected a number'),
                 (lambda d: d["persp"].__setitem__("fx", 1e300),
                  "persp.fx: got 1e+300 (number), expected a number in [1.0, 100000.0]")]
        for edit, msg in cases:
            with self.subTest(msg=msg):
                self.refused(["calib", "show", self.calib(edit)], 1, msg)

    def test_unknown_key_is_reported(self):
        r = self.bv("calib", "show", self.calib(lambda d: d["persp"].__setitem__("fxx", 1)))
        self.assertEqual(r.returncode, 0)
        self.assertIn("warning: ", r.stderr)
        self.assertIn("c.json: persp.fxx: unknown key, ignored", r.stderr)

    def test_truncated_and_not_json(self):
        p = self.path("c.json")
        write(p, read(REF)[:200])
        self.refused(["calib", "show", p], 1, "c.json: not valid JSON (")
        write(p, '{"format": NaN}')
        self.refused(["calib", "show", p], 1, "c.json: not valid JSON (")

    def test_calib_set_values(self):
        p = self.calib(lambda d: None)
        self.refused(["calib", "set", p, "--ball-radius", "0.1x"], 2,
                     "--ball-radius: got '0.1x', expected a number in [0.01, 1]", [p])
        self.refused(["calib", "set", p, "--ball-radius", "5"], 2, "expected a number", [p])
        self.refused(["calib", "set", p, "--lut-id", "0x1FFFFFFFF"], 2, "32-bit id", [p])
        self.refused(["calib", "set", p, "--lut-id", "5", "--ball-radius"], 2, "usage", [p])


class Outputs(Base):
    def test_symlink_fifo_device_refused(self):
        victim = self.path("victim")
        write(victim, "KEEP")
        link = self.path("link.bin")
        os.symlink(victim, link)
        self.refused(["calib", "to-blob", REF, link], 1,
                     f"refusing to write {link}: it is a symbolic link", [victim])
        fifo = self.path("fifo.bin")
        os.mkfifo(fifo)
        self.refused(["calib", "to-blob", REF, fifo], 1, "it is a FIFO")
        self.refused(["calib", "to-blob", REF, "/dev/null"], 1, "it is a device")
        self.refused(["lut", "train", "--out", link, "--teach", "x.png:1,1"], 1,
                     "it is a symbolic link", [victim])
        self.refused(["listen", GOLDEN, "--csv", link], 1, "it is a symbolic link", [victim])
        self.refused(["run", self.seq(), "--calib", REF, "--out", link], 1,
                     "it is a symbolic link", [victim])

    def test_file_size_limit_is_an_error_and_keeps_the_old_file(self):
        out = self.path("out.json")
        write(out, "OLD")

        def limit():
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))
        before = read(out)
        r = subprocess.run([BV, "calib", "to-json", REF, out], capture_output=True, text=True,
                           preexec_fn=limit)
        self.assertEqual(r.returncode, 1, r.stderr)
        self.assertIn("write to " + out + " failed: File too large", r.stderr)
        self.assertEqual(read(out), before)
        self.assertEqual([f for f in os.listdir(self.d) if f.startswith(".")], [])

    def test_closed_or_full_stdout(self):
        r = subprocess.run([BV, "calib", "show", REF], capture_output=True, text=True,
                           preexec_fn=lambda: os.close(1))
        self.assertEqual(r.returncode, 1)
        self.assertIn("standard output is closed", r.stderr)
        with open("/dev/full", "w") as full:
            r = subprocess.run([BV, "calib", "show", REF], stdout=full, stderr=subprocess.PIPE,
                               text=True)
        self.assertEqual(r.returncode, 1)
        self.assertIn("writing to standard output failed: No space left on device", r.stderr)


class Sequences(Base):
    def test_png_of_the_wrong_size(self):
        s = self.seq(persp_size=(320, 240))
        out = self.path("states.csv")
        self.refused(["run", s, "--calib", REF, "--out", out], 1,
                     "p0.png: image is 320x240, expected 640x480 (the calibration's persp image "
                     "size)", [out])

    def test_garbage_truth(self):
        s = self.seq(truth="\x00\x01garbage\nnot,a,csv\n")
        self.refused(["eval", s, "--calib", REF], 1, "truth.csv:1: header lacks column 't_us'")
        lut = self.path("t.lut")
        self.refused(["lut", "train", "--out", lut, "--sim", s], 1,
                     "truth.csv:1: header lacks column 'index'", [lut])
        self.refused(["lut", "eval", "--lut", os.path.join(HERE, "data", "luts", "sim_orange.lut"),
                      "--sim", s], 1, "truth.csv:1: header lacks column 'index'")

    def test_truth_bad_line_named(self):
        s = self.seq(truth="index,t_us,ball_x,ball_y,ball_z\n0,0,1,2,3\n1,100,1,2,abc\n")
        self.refused(["eval", s, "--calib", REF], 1,
                     "truth.csv:3: column ball_z: got 'abc', expected a number")
        s = self.seq(truth="index,t_us,ball_x,ball_y,ball_z\n0,1.5,1,2,3\n")
        self.refused(["eval", s, "--calib", REF], 1, "truth.csv:2: column t_us: got '1.5'")
        s = self.seq(truth="index,t_us,ball_x,ball_y,ball_z\n")
        self.refused(["eval", s, "--calib", REF], 1, "truth.csv: no data rows")

    def test_frames_csv_and_grid_csv(self):
        s = self.seq()
        write(self.path("s/frames.csv"), "index,t_us,omni_file,persp_file\n0,12x,,p0.png\n")
        self.refused(["run", s, "--calib", REF], 1,
                     "frames.csv:2: t_us '12x' is not a non-negative integer")
        s = self.seq(truth="index,t_us,ball_x,ball_y,ball_z\n0,0,1,2,3\n")
        write(self.path("s/grid.csv"), "index,bearing_deg,distance_m,z_m\n0,0.0,far,0.11\n")
        self.refused(["eval", s, "--calib", REF], 1,
                     "grid.csv:2: column distance_m: got 'far', expected a number")

    def test_carpet_and_poses(self):
        s = self.seq()
        carpet = {"edges_m": [0.3 + 0.5 * i for i in range(17)],
                  "colors": ["white", "blue"] * 8, "frames": [{"index": 0, "t_us": 0}]}
        for edit, msg in ((lambda c: c["colors"].__setitem__(3, "green"),
                           'carpet.json: colors[3]: got "green" (string), expected "white"'),
                          (lambda c: c.__setitem__("width_m", "0.6"),
                           'carpet.json: width_m: got "0.6" (string), expected a number'),
                          (lambda c: None,
                           "carpet.json: frames[0].carpet_azimuth_robot_deg: missing")):
            c = json.loads(json.dumps(carpet))
            edit(c)
            write(self.path("s/carpet.json"), json.dumps(c))
            out = self.path("o.json")
            with self.subTest(msg=msg):
                self.refused(["calibrate", "omni", s, "--viewpoint-z", "0.4", "--out", out], 1,
                             msg, [out])
        write(self.path("c.csv"), "image,corner,X,Y,u,v,in_image\n")
        eye = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
        for pose, msg in (({"image": 3, "R": eye, "t": [0, 0, 1]},
                           "poses.json: poses[0].image: got 3 (integer), expected a string"),
                          ({"image": "a.png", "R": [[1, 0, 0], [0, 1, "0"], [0, 0, 1]],
                            "t": [0, 0, 1]},
                           'poses.json: poses[0].R[1][2]: got "0" (string), expected a number'),
                          ({"image": "a.png", "R": eye, "t": [0, 0]},
                           "poses.json: poses[0].t: got [0,0] (array), expected 3 numbers (m)"),
                          ({"image": "a.png", "R": [[1, 0, 0], [0, 1, 0], [0, 0, 0.5]],
                            "t": [0, 0, 1]}, "poses.json: poses[0].R (a.png) is not a rotation")):
            write(self.path("poses.json"), json.dumps({"poses": [pose]}))
            with self.subTest(msg=msg):
                self.refused(["calibrate", "persp", "--corners", self.path("c.csv"), "--poses",
                              self.path("poses.json"), "--out", self.path("o.json")], 1, msg)

    def test_lut_blob_garbage(self):
        write(self.path("bad.lut"), b"BVB1" + bytes(100))
        self.refused(["lut", "show", self.path("bad.lut")], 1, "bad.lut: blob: ")

    def test_lut_train_without_sources(self):
        lut = self.path("t.lut")
        self.refused(["lut", "train", "--out", lut], 2, "no training source", [lut])

    def test_lut_teach_refusals_keep_the_old_table(self):
        lut = self.path("t.lut")
        write(lut, b"old table")
        s = self.seq()  # one grey persp frame: nothing ball-coloured anywhere
        self.refused(["lut", "teach", s, "--out", lut], 1, "the ball was found in no frame", [lut])
        self.refused(["lut", "teach", s, "--out", lut, "--click", "0:persp:300,200"], 1,
                     "no ball-coloured region at the click (persp frame 0, pixel 300, 200)", [lut])
        self.refused(["lut", "teach", s, "--out", lut, "--click", "7:persp:300,200"], 1,
                     "the click's frame 7 is not in", [lut])
        self.refused(["lut", "teach", s, "--out", lut, "--click", "0:side:3,4"], 2,
                     "camera 'side', expected omni or persp", [lut])
        self.refused(["lut", "teach", s, "--out", lut, "--click", "0:persp"], 2,
                     "expected INDEX:CAMERA:U,V", [lut])
        self.refused(["lut", "teach", "--out", lut], 2, "give a sequence SEQ or annotated", [lut])
        self.refused(["lut", "teach", self.path("nope"), "--out", lut], 1, "frames.csv", [lut])

    def test_numbers_on_the_command_line(self):
        s = self.seq()
        for args, msg in ((["listen", GOLDEN, "--baud", "12x"], "--baud: got '12x'"),
                          (["listen", GOLDEN, "--baud", "12345"], "--baud: unsupported rate"),
                          (["listen", GOLDEN, "--seconds", "nan"], "--seconds: got 'nan'"),
                          (["lut", "train", "--out", "x", "--every", "0", "--sim", s],
                           "--every: got '0', expected an integer in [1, 1000000]"),
                          (["lut", "eval", "--lut", "x", "--center", "1,y"], "--center: got 'y'"),
                          (["calibrate", "omni", s, "--viewpoint-z", "1e999", "--out", "x"],
                           "--viewpoint-z: got '1e999'"),
                          (["calibrate", "persp", "--corners", "c.csv", "--out", "x", "--size",
                            "640x-1"], "--size: got '-1'")):
            with self.subTest(args=args):
                self.refused(args, 2, msg)


# Every command and sub-command answers --help the same way (issue 14): usage on stdout, exit
# 0, nothing on stderr; a bad option exits 2 with the message and the usage on stderr.
SUBCOMMANDS = {"lut": ["train", "eval", "show"], "calibrate": ["persp", "omni"],
               "calib": ["to-blob", "to-json", "show", "set"], "seq": ["info", "to-raw"]}


class Help(Base):
    def commands(self):
        """The top-level commands, from `ballvision --help` (so a new one is checked too)."""
        r = self.bv("--help")
        self.assertEqual(r.returncode, 0, r.stderr)
        names = [line.split()[0] for line in r.stdout.split("commands:\n")[1].splitlines()
                 if line.startswith("  ")]
        self.assertIn("run", names)
        out = []
        for name in names:
            out.append([name])
            out += [[name, sub] for sub in SUBCOMMANDS.get(name, [])]
        return out

    def test_help_everywhere(self):
        for cmd in [[]] + self.commands():
            for flag in ("--help", "-h"):
                with self.subTest(cmd=cmd, flag=flag):
                    r = self.bv(*cmd, flag)
                    self.assertEqual(r.returncode, 0, r.stderr)
                    self.assertTrue(r.stdout.startswith("usage: ballvision"), r.stdout)
                    self.assertEqual(r.stderr, "")

    def test_help_after_other_arguments_and_as_a_value(self):
        # Once taken as the value of --out / opened as a file named "--help".
        for cmd in (["lut", "train", "--out", "--help"], ["lut", "show", "--help"],
                    ["run", "SEQ", "--calib", "--help"], ["listen", "x", "--csv", "--help"]):
            with self.subTest(cmd=cmd):
                r = self.bv(*cmd)
                self.assertEqual(r.returncode, 0, r.stderr)
                self.assertTrue(r.stdout.startswith("usage: ballvision"), r.stdout)

    def test_bad_option_is_a_usage_error(self):
        for cmd in self.commands():
            with self.subTest(cmd=cmd):
                r = self.bv(*cmd, "--no-such-option", "1")
                self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
                self.assertIn("--no-such-option", r.stderr)
                self.assertIn("usage: ballvision", r.stderr)
                self.assertEqual(r.stdout, "")

    def test_an_option_is_not_a_value(self):
        s = self.seq()
        for args, msg in ((["run", s, "--calib", "--out", "x"], "--calib needs a value"),
                          (["lut", "train", "--out", "--sim", s], "--out needs a value"),
                          (["seq", "to-raw", s, self.d, "--first", "--count"],
                           "--first needs a value")):
            with self.subTest(args=args):
                r = self.refused(args, 2, msg)
                self.assertIn("usage: ballvision", r.stderr)

    def test_no_silent_clamping_or_truncation(self):
        s = self.seq()
        for args, msg in ((["demo", "--frames", "3", "--out", self.d],
                           "--frames: got '3', expected an integer in [10, "),
                          (["run", s, "--calib", REF, "--predict-ms", "200.5"],
                           "--predict-ms: got '200.5', expected an integer"),
                          (["eval", s, "--calib", REF, "--bounce-factor", "1"],
                           "--bounce-factor: got '1', expected a number in (0, 1)")):
            with self.subTest(args=args):
                self.refused(args, 2, msg)


def frames(n):
    sys.path.insert(0, PYLINK)
    from ballvision_link.protocol import encode_frame, cobs_decode
    golden = read(GOLDEN, "rb")
    first = golden[:golden.index(0)]
    payload = cobs_decode(first)[10:-4]
    return b"".join(encode_frame(1, i, payload) for i in range(n)), golden


class Signals(Base):
    def interrupt(self, cmd, sig, env=None):
        data, golden = frames(72)
        p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, env=env)
        p.stdin.write(data + golden)  # 72 + 1 ball states, 1 status
        p.stdin.flush()
        # The temporary CSV exists once the listener runs (its handlers are installed by then).
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and not any(
                f.startswith(".t.csv.") for f in os.listdir(self.d)):
            time.sleep(0.05)
        time.sleep(0.5)
        p.send_signal(sig)
        out, err = p.communicate(timeout=20)
        return p.returncode, out.decode(), err.decode()

    def check(self, rc, out, err, sig):
        self.assertEqual(rc, 128 + sig, err)
        self.assertIn("summary: ball_states=73 status=1", out)
        self.assertNotIn("Traceback", err)
        self.assertEqual(len(read(self.path("t.csv")).splitlines()), 1 + 73)
        self.assertEqual(len(read(self.path("s.csv")).splitlines()), 1 + 1)

    def test_cpp_listen_sigint_and_sigterm_keep_every_row(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            with self.subTest(sig=sig):
                self.check(*self.interrupt([BV, "listen", "-", "--csv", self.path("t.csv"),
                                            "--status-csv", self.path("s.csv"), "--quiet"], sig),
                           sig)

    @unittest.skipUnless(os.path.isdir(BOUNCE), "shared data absent")
    def test_eval_sigma_errors_are_the_axes_it_scored(self):
        # The per-axis file is what pools the calibration over sequences: the same axes and the
        # same fraction within 1 sigma as the printed figure; a symlink is refused.
        out = self.path("se.csv")
        r = self.bv("eval", BOUNCE, "--calib", REF, "--lut", "builtin", "--sigma-errors", out)
        self.assertEqual(r.returncode, 0, r.stderr)
        line = [l for l in r.stdout.splitlines() if l.startswith("uncertainty: ")][0]
        within = float(line.split("1-sigma on ")[1].split(" %")[0])
        n = int(line.split("n=")[1].split(")")[0])
        rows = read(out).splitlines()
        self.assertEqual(rows[0], "index,phase,axis,error_m,sigma_m")
        vals = [row.split(",") for row in rows[1:]]
        self.assertEqual(len(vals), n)
        inside = sum(abs(float(v[3])) <= float(v[4]) for v in vals)
        self.assertAlmostEqual(100.0 * inside / n, within, delta=0.051)
        self.assertTrue(all(float(v[4]) > 0 and v[2] in "xyz" for v in vals))
        victim = self.path("victim")
        write(victim, "KEEP")
        link = self.path("link.csv")
        os.symlink(victim, link)
        r = self.refused(["eval", BOUNCE, "--calib", REF, "--lut", "builtin", "--sigma-errors",
                          link], 1, "it is a symbolic link", [victim])
        self.assertEqual(r.stdout, "")  # refused before the sequence ran

    @unittest.skipUnless(os.path.isdir(BOUNCE), "shared data absent")
    def test_run_sigint_writes_the_frames_done(self):
        out = self.path("st.csv")
        p = subprocess.Popen([BV, "run", BOUNCE, "--calib", REF, "--out", out],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        seen = b""
        while b"/60 frames" not in seen:  # the progress bar: frames are being processed
            chunk = os.read(p.stderr.fileno(), 4096)
            self.assertTrue(chunk, "run ended before it showed progress")
            seen += chunk
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=60)
        err = (seen + err).decode()
        self.assertEqual(p.returncode, 130, err)
        self.assertIn("interrupted by SIGINT", err)
        rows = len(read(out).splitlines()) - 1
        self.assertIn(f"{rows} frames, ball found in", err)
        self.assertTrue(0 < rows < 60, rows)

    def test_python_listen_sigint_and_sigterm(self):
        env = dict(os.environ, PYTHONPATH=PYLINK)
        for sig in (signal.SIGINT, signal.SIGTERM):
            with self.subTest(sig=sig):
                self.check(*self.interrupt([sys.executable, "-m", "ballvision_link", "-", "--csv",
                                            self.path("t.csv"), "--status-csv",
                                            self.path("s.csv"), "--quiet"], sig, env), sig)

    def test_same_csv_from_both_listeners(self):
        data, golden = frames(5)
        src = self.path("cap.bin")
        write(src, data + golden)
        kinds = ("pose", "lines", "obstacles", "goals")  # the golden file's field packets
        field = lambda who: sum((["--%s-csv" % k, self.path("%s_%s.csv" % (who, k))]
                                 for k in kinds), [])
        r1 = self.bv("listen", src, "--csv", self.path("c.csv"), "--status-csv",
                     self.path("cs.csv"), "--quiet", *field("c"))
        r2 = subprocess.run([sys.executable, "-m", "ballvision_link", src, "--csv",
                             self.path("p.csv"), "--status-csv", self.path("ps.csv"), "--quiet",
                             *field("p")],
                            env=dict(os.environ, PYTHONPATH=PYLINK), capture_output=True)
        self.assertEqual((r1.returncode, r2.returncode), (0, 0))
        self.assertEqual(read(self.path("c.csv")), read(self.path("p.csv")))
        self.assertEqual(read(self.path("cs.csv")), read(self.path("ps.csv")))
        for k in kinds:
            self.assertEqual(read(self.path("c_%s.csv" % k)), read(self.path("p_%s.csv" % k)), k)
        self.assertIn("0.25,4.5,1.515,0.25,4,1,1,1", read(self.path("c_goals.csv")))


class PythonSources(Base):
    def test_tcp_waits_through_silence(self):
        srv = socket.socket()
        srv.bind(("127.0.0.1", 0))
        srv.listen(1)
        port = srv.getsockname()[1]
        golden = read(GOLDEN, "rb")

        def serve():
            c, _ = srv.accept()
            time.sleep(6)  # longer than the old 5 s socket timeout
            c.sendall(golden)
            c.close()
        threading.Thread(target=serve, daemon=True).start()
        r = subprocess.run([sys.executable, "-m", "ballvision_link", f"tcp:127.0.0.1:{port}",
                            "--quiet"], env=dict(os.environ, PYTHONPATH=PYLINK),
                           capture_output=True, text=True, timeout=30)
        srv.close()
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("summary: ball_states=1 status=1", r.stdout)

    def test_missing_pyserial_is_one_line(self):
        code = ("import sys; sys.modules['serial'] = None; "
                "from ballvision_link.__main__ import main; sys.exit(main(['/dev/ttyNONE']))")
        r = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, PYTHONPATH=PYLINK),
                           capture_output=True, text=True)
        self.assertNotEqual(r.returncode, 0)
        self.assertEqual(r.stderr.strip().splitlines(),
                         ["ballvision_link: reading a serial port needs pyserial "
                          "(apt install python3-serial, or pip install pyserial)"])



class ReadBack(Base):
    """`ballvision readback` against a fake device on TCP that answers `serve` reads of a blob,
    then hangs up: nothing is written, the old file is kept, the message says how far it got."""
    def device(self, blob, serve):
        sys.path.insert(0, PYLINK)
        from ballvision_link.protocol import Decoder, encode_frame
        srv = socket.socket()
        srv.bind(("127.0.0.1", 0))
        srv.listen(1)

        def run():
            c, _ = srv.accept()
            dec, served = Decoder(), 0
            while served < serve:
                data = c.recv(4096)
                if not data:
                    break
                for m in dec.feed(data):
                    if not isinstance(m, tuple) or m[0] != 0x2C:
                        continue
                    _, off, n = struct.unpack("<BIH", m[2])
                    head = struct.pack("<IBIII", m[1], 2, len(blob), zlib.crc32(blob), off)
                    c.sendall(encode_frame(0x0E, served, head + blob[off:off + n]))
                    served += 1
            c.close()
            srv.close()
        threading.Thread(target=run, daemon=True).start()
        return f"tcp:127.0.0.1:{srv.getsockname()[1]}"

    def test_a_read_cut_off_writes_nothing(self):
        out = self.path("table.lut")
        write(out, b"old table")
        src = self.device(bytes(range(256)) * 20, 4)
        self.refused(["readback", src, "--out", out, "--seconds", "20"], 1,
                     "ballvision readback: the link closed after 2048 of 5120 bytes; "
                     f"{out} not written", keep=[out])

    def test_a_blob_that_does_not_parse_is_not_written(self):
        out = self.path("table.lut")
        src = self.device(bytes(range(256)) * 2, 10)
        self.refused(["readback", src, "--out", out, "--seconds", "20"], 1,
                     "the blob read back does not parse: ", keep=[out])
        self.assertFalse(os.path.exists(out))

    def test_a_recording_or_a_bad_choice_is_refused(self):
        self.refused(["readback", GOLDEN, "--out", self.path("t.lut")], 1,
                     "is a recording; a read-back needs a live link")
        self.refused(["readback", GOLDEN, "--out", self.path("t.lut"), "--what", "x"], 2,
                     "--what: got 'x', expected lut, calibration or classifier")

if __name__ == "__main__":
    BV = os.path.abspath(sys.argv.pop(1))
    unittest.main()
