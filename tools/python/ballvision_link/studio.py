"""python3 -m ballvision_link.studio SOURCE [--calib FILE] [--lut FILE|builtin] [--port N]
                                      [--ballvision BIN] [--work DIR] [--baud N]

The venue tool in a browser: both cameras' frames with the scanlines, classified pixels and the
chosen ball; a click on the ball teaches its colour (`ballvision lut teach`, one step) and the
frames are classified again; the table can be saved or uploaded; a top view of the field with
the robot, the ball, its predicted path, touchdown point and obstacles; the height and vertical
velocity over time (the paper's Fig. 5) and the status counters.

SOURCE is a captured sequence (a folder with frames.csv) or the coprocessor's link (a serial
port, or tcp:HOST:PORT); with a link, `--seq DIR` also opens a sequence to teach on, and "grab"
captures one from the device. The page is served on 127.0.0.1 only and needs no internet: all
it loads is in ballvision_link/studio_assets. Frames are processed by the `ballvision` program
(--ballvision, $BV_BALLVISION, PATH, or build/host/tools/ballvision of this source tree)."""
import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import parse_qs, urlparse

from . import commands
from .clock_sync import ClockSync
from .protocol import (BallState, ClockSyncReply, Decoder, LinePoints, Obstacles, Pose,
                       StatusReport, FLAG_HAS_BOUNCE, camera_check_text)
from .studio_capture import CaptureWriter
from .sync import _Link, now_us

ASSETS = Path(__file__).with_name("studio_assets")
CONTENT_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
                 ".css": "text/css; charset=utf-8", ".png": "image/png"}
LIVE_HISTORY = 900  # ball states kept for the live plot (30 s at 30 Hz)


def find_ballvision(arg):
    """The ballvision program, or None."""
    for c in (arg, os.environ.get("BV_BALLVISION"), shutil.which("ballvision"),
              str(Path(__file__).resolve().parents[3] / "build/host/tools/ballvision")):
        if c and os.access(c, os.X_OK) and Path(c).is_file():
            return c
    return None


def _finite(o):
    """JSON has no NaN / inf: they become null."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: _finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite(v) for v in o]
    return o


def _num(v):
    return float(v) if v not in ("", None) else None


def _read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


class SequenceView:
    """A captured sequence processed by `ballvision run`; each teach makes a new generation."""

    def __init__(self, ballvision, calib, lut, work):
        self.bv, self.calib, self.lut, self.work = ballvision, calib, lut, Path(work)
        self.lock = threading.Lock()
        self.gen, self.dir, self.error, self.data = 0, None, None, None
        self.teach_report, self.lut_used = None, None

    def open(self, path, lut=None):
        with self.lock:
            if lut is not None:
                self.lut = lut
            p = Path(path)
            if not p.is_dir():
                return self._fail(f"{path}: no such folder")
            if not (p / "frames.csv").is_file():
                return self._fail(f"{path} is not a captured sequence: it has no frames.csv "
                                  "(DESIGN.md section 4)")
            self.dir, self.teach_report = str(p.resolve()), None
            return self._process()

    def _fail(self, msg):
        self.error, self.data = msg, None
        return False

    def _run(self, args, what):
        if not self.bv:
            return None, ("the ballvision program was not found: build it (cmake --build --preset "
                          "host) or give --ballvision BIN")
        try:
            r = subprocess.run([self.bv] + args, capture_output=True, text=True, timeout=600)
        except (OSError, subprocess.TimeoutExpired) as e:
            return None, f"{what}: {e}"
        if r.returncode != 0:
            lines = [ln for ln in r.stderr.splitlines() if ln.strip() and "\r" not in ln]
            return None, f"{what} failed: " + (" / ".join(lines[-3:]) or f"exit {r.returncode}")
        return r, None

    def _process(self):
        self.gen += 1
        out = self.work / f"gen{self.gen}"
        out.mkdir(parents=True, exist_ok=True)
        args = ["run", self.dir, "--calib", self.calib, "--out", str(out / "states.csv"),
                "--annotate", str(out), "--features", str(out), "--paths", str(out / "paths.csv")]
        if self.lut:
            args += ["--lut", self.lut]
        r, err = self._run(args, "ballvision run")
        if err:
            return self._fail(err)
        used = [ln for ln in r.stderr.splitlines() if ln.startswith("colour LUT:")]
        self.lut_used = used[0][len("colour LUT:"):].strip() if used else self.lut
        try:
            self.data = self._load(out)
        except (OSError, ValueError, KeyError) as e:
            return self._fail(f"reading the output of ballvision run in {out}: {e}")
        self.error = None
        return True

    def _load(self, out):
        frames = []
        for row in _read_csv(out / "states.csv"):
            f = {k: _num(row.get(k)) for k in ("t_us", "x", "y", "z", "vx", "vy", "vz", "omni_u",
                                                  "omni_v", "persp_u", "persp_v", "ray_gap",
                                                  "proc_us", "pose_x", "pose_y",
                                                  "pose_heading_deg")}
            f.update(index=int(row["index"]), found=row["found"] == "1", mode=row["mode"])
            f["images"] = [c for c in ("omni", "persp")
                           if (out / f"{c}_{f['index']:06d}.png").is_file()]
            frames.append(f)
        paths, contacts, obstacles = {}, {}, {}
        for row in _read_csv(out / "paths.csv"):
            i, p = row["index"], [float(row["t_us"]), float(row["x"]), float(row["y"]),
                                  float(row["z"])]
            (paths if row["kind"] == "path" else contacts).setdefault(i, []).append(p)
        for row in _read_csv(out / "obstacles.csv"):
            obstacles.setdefault(row["index"], []).append(
                [float(row["x"]), float(row["y"]), float(row["radius"])])
        lines = {}
        for row in _read_csv(out / "lines.csv"):
            lines[row["index"]] = lines.get(row["index"], 0) + 1
        for f in frames:
            k = str(f["index"])
            f["path"], f["contacts"] = paths.get(k, []), contacts.get(k, [])
            f["obstacles"], f["line_points"] = obstacles.get(k, []), lines.get(k, 0)
        return {"frames": frames}

    def teach(self, index, camera, u, v):
        with self.lock:
            if not self.dir or self.data is None:
                return False, "no sequence is open"
            out = self.work / f"taught_{self.gen}.lut"
            r, err = self._run(["lut", "teach", self.dir, "--out", str(out), "--click",
                                f"{index}:{camera}:{u:.1f},{v:.1f}"], "ballvision lut teach")
            if err:
                return False, err + "; the old table stays"
            self.lut, self.teach_report = str(out), r.stdout.strip()
            if not self._process():
                return False, self.error
            return True, self.teach_report

    def summary(self):
        with self.lock:
            return {"dir": self.dir, "gen": self.gen, "error": self.error, "lut": self.lut_used,
                    "lut_file": self.lut if self.lut and Path(self.lut).is_file() else None,
                    "teach": self.teach_report, "calib": self.calib,
                    **(self.data or {"frames": []})}


class LiveLink:
    """The coprocessor's link, read by a thread: the latest states, pose, features, status and
    clock sync; commands wait for their ack. A link that ends is retried every 2 s."""

    def __init__(self, source, baud, capture_dir):
        self.source, self.baud, self.capture_dir = source, baud, Path(capture_dir)
        self.cv = threading.Condition()
        self.link, self.connected, self.error = None, False, None
        self.states, self.pose, self.obstacles, self.lines, self.status = [], None, None, None, None
        self.replies, self.packets, self.next_seq = {}, 0, 100
        self.sync = ClockSync(baud=baud)
        self.capture, self.capture_msg, self.on_capture = None, None, None
        self.dec = Decoder()
        self.stop = False
        threading.Thread(target=self._loop, daemon=True).start()

    def _loop(self):
        while not self.stop:
            try:
                link = _Link(self.source, self.baud)
            except (OSError, ValueError, SystemExit) as e:
                self._lost(f"cannot open {self.source}: {e}")
                time.sleep(2.0)
                continue
            with self.cv:
                self.link, self.connected, self.error, self.dec = link, True, None, Decoder()
                self.sync = ClockSync(baud=self.baud)
            try:
                self._read(link)
            except (OSError, EOFError) as e:
                self._lost(f"the link to {self.source} ended: {e} (retrying every 2 s)")
                time.sleep(2.0)

    def _lost(self, msg):
        with self.cv:
            self.link, self.connected, self.error = None, False, msg
            if self.capture is not None:
                self.capture_msg = self.capture.finish("cut off: the link ended")
                self.capture = None
            self.cv.notify_all()

    def _read(self, link):
        next_status = next_sync = time.monotonic()
        rid = 0
        while not self.stop:
            now = time.monotonic()
            if now >= next_status:
                self.send(commands.request_status(self._seq()))
                next_status = now + 1.0
            if now >= next_sync:
                rid += 1
                t1 = now_us()
                self.sync.request_sent(rid, t1)
                self.send(commands.clock_sync(self._seq(), rid, t1))
                next_sync = now + 0.5
            for msg in self.dec.feed(link.read()):
                self._dispatch(msg)

    def _seq(self, count=1):
        """The first of `count` fresh command sequence numbers."""
        with self.cv:
            self.next_seq += count
            return self.next_seq - count + 1

    def _dispatch(self, msg):
        with self.cv:
            self.packets += 1
            if isinstance(msg, BallState):
                self.states.append(msg)
                del self.states[:-LIVE_HISTORY]
            elif isinstance(msg, Pose):
                self.pose = msg
            elif isinstance(msg, Obstacles):
                self.obstacles = msg
            elif isinstance(msg, LinePoints):
                self.lines = msg
            elif isinstance(msg, StatusReport):
                self.status = msg
            elif isinstance(msg, ClockSyncReply):
                self.sync.reply(msg, now_us())
            elif isinstance(msg, tuple):
                reply = commands.parse_reply(msg[0], msg[2])
                if reply is not None:
                    self.replies[reply[1]] = reply
                    self.cv.notify_all()
            if self.capture is not None:
                writer = self.capture
                done, text = writer.feed(msg)
                if done:
                    self.capture_msg, self.capture = text, None
                    if self.on_capture and writer.rows:  # open what was written
                        threading.Thread(target=self.on_capture, args=(str(writer.out),),
                                         daemon=True).start()

    def send(self, frame):
        link = self.link
        if link is None:
            raise OSError(self.error or "not connected")
        link.write(frame)

    def command(self, frame, seq, timeout=3.0):
        """Sends one command frame numbered `seq` and waits for its reply: None when
        acknowledged, else the error text."""
        try:
            self.send(frame)
        except (OSError, EOFError) as e:
            return f"not sent: {e}"
        deadline = time.monotonic() + timeout
        with self.cv:
            while seq not in self.replies:
                left = deadline - time.monotonic()
                if not self.connected:
                    return self.error
                if left <= 0:
                    return "no answer from the coprocessor"
                self.cv.wait(left)
            return self.replies.pop(seq)[2]

    def upload_lut(self, blob):
        # begin, the chunks, commit: one sequence number each
        count = 2 + (len(blob) + commands.MAX_CHUNK - 1) // commands.MAX_CHUNK
        seq0 = self._seq(count)
        frames = commands.upload(seq0, commands.TARGET_LUT, blob)
        for i, frame in enumerate(frames):
            err = self.command(frame, seq0 + i)
            if err:
                return f"upload refused at packet {i + 1}/{len(frames)}: {err}; the old table stays"
        return None

    def start_capture(self, pairs, mode):
        with self.cv:
            if self.capture is not None:
                return "a capture is already running"
            out = self.capture_dir / time.strftime("capture_%Y%m%d_%H%M%S")
            self.capture, self.capture_msg = CaptureWriter(out, pairs, mode), None
        seq = self._seq()
        err = self.command(commands.capture_start(seq, pairs, mode), seq)
        if err:
            with self.cv:
                self.capture = None
            return f"capture refused: {err}"
        return None

    def summary(self):
        with self.cv:
            st = [_state_dict(s) for s in self.states[-300:]]
            sync = None
            if self.sync.valid:
                sync = {"offset_us": self.sync.offset_us(self.states[-1].t_us if self.states else 0),
                        "drift_ppm": self.sync.drift_ppm, "min_delay_us": self.sync.min_delay_us}
            return {"source": self.source, "connected": self.connected, "error": self.error,
                    "packets": self.packets, "decoder_errors": dict(self.dec.errors),
                    "states": st, "pose": self.pose.__dict__ if self.pose else None,
                    "obstacles": self.obstacles.obstacles if self.obstacles else [],
                    "status": _status_dict(self.status) if self.status else None, "sync": sync,
                    "capture": "running" if self.capture else self.capture_msg}


def _status_dict(st):
    d = dict(st.__dict__)
    for cam in ("omni", "persp"):
        text = camera_check_text(getattr(st, "check_" + cam))
        change, conf = getattr(st, "change_" + cam + "_deg"), getattr(st, "confidence_" + cam)
        if change > 0:
            text += f", changed {change:.2f}° (confidence {conf:.0%})"
        d[cam + "_camera"] = text
    return d


def _state_dict(s):
    d = {"t_us": s.t_us, "found": s.found, "mode": s.mode, "x": s.x, "y": s.y, "z": s.z,
         "vx": s.vx, "vy": s.vy, "vz": s.vz, "proc_us": s.proc_us, "persp_u": s.persp_u,
         "omni_u": s.omni_u, "sigma": [s.sigma_x, s.sigma_y, s.sigma_z]}
    if s.flags & FLAG_HAS_BOUNCE and s.t_bounce_us is not None:
        d["contacts"] = [[s.t_bounce_us, s.bounce_x, s.bounce_y, 0.0]]
    return d


def load_field(calib):
    """The field section of the calibration JSON (MSL defaults when it has none)."""
    field = {"length": 18.0, "width": 12.0, "center_circle_radius": 2.0, "penalty_area_depth": 2.25,
             "penalty_area_width": 6.5, "goal_area_depth": 0.75, "goal_area_width": 3.5,
             "goal_width": 2.0, "goal_depth": 0.6, "border": 1.5}
    try:
        with open(calib) as f:
            field.update(json.load(f).get("field", {}))
    except (OSError, ValueError, AttributeError):
        pass
    return field


class Studio:
    def __init__(self, a):
        self.work = Path(a.work or tempfile.mkdtemp(prefix="bv_studio_"))
        self.seq = SequenceView(find_ballvision(a.ballvision), a.calib, a.lut, self.work)
        self.field = load_field(a.calib)
        self.live = None
        seq_dir = a.seq
        if _is_link(a.source):
            self.live = LiveLink(a.source, a.baud, self.work)
            self.live.on_capture = self.seq.open
        else:
            seq_dir = a.source
        if seq_dir:
            self.seq.open(seq_dir)

    def state(self):
        return {"field": self.field, "work": str(self.work), "sequence": self.seq.summary(),
                "live": self.live.summary() if self.live else None}


def _is_link(src):
    return src.startswith("tcp:") or src.startswith("/dev/") or Path(src).is_char_device()


class Handler(BaseHTTPRequestHandler):
    studio = None  # set by serve()

    def log_message(self, fmt, *args):  # quiet: the page shows what matters
        pass

    def _send(self, code, body, ctype="application/json"):
        data = body if isinstance(body, bytes) else json.dumps(_finite(body)).encode()
        self.send_response(code)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(data)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(data)

    def do_GET(self):
        url = urlparse(self.path)
        q = {k: v[0] for k, v in parse_qs(url.query).items()}
        s = self.studio
        if url.path in ("/", "/index.html"):
            return self._file(ASSETS / "index.html")
        if url.path.startswith("/assets/"):
            name = url.path[len("/assets/"):]
            if "/" in name or name.startswith("."):
                return self._send(404, {"error": "no such asset"})
            return self._file(ASSETS / name)
        if url.path == "/api/state":
            return self._send(200, s.state())
        if url.path == "/api/frame":
            return self._frame(q)
        if url.path == "/api/lut":
            f = s.seq.summary()["lut_file"]
            if not f:
                return self._send(404, {"error": "no taught table yet"})
            return self._send(200, Path(f).read_bytes(), "application/octet-stream")
        return self._send(404, {"error": f"no such page: {url.path}"})

    def _file(self, path):
        try:
            self._send(200, path.read_bytes(), CONTENT_TYPES.get(path.suffix, "text/plain"))
        except OSError:
            self._send(404, {"error": f"missing asset {path.name}"})

    def _frame(self, q):
        s = self.studio.seq
        cam, gen = q.get("cam"), q.get("gen", "")
        if cam not in ("omni", "persp") or not q.get("i", "").isdigit() or not gen.isdigit():
            return self._send(400, {"error": "frame: cam=omni|persp&i=INDEX&gen=N"})
        path = s.work / f"gen{int(gen)}" / f"{cam}_{int(q['i']):06d}.png"
        if not path.is_file():
            return self._send(404, {"error": f"no {cam} image for frame {q['i']}"})
        self._send(200, path.read_bytes(), "image/png")

    def do_POST(self):
        try:
            n = int(self.headers.get("Content-Length", "0"))
            body = json.loads(self.rfile.read(n) or b"{}") if 0 <= n <= 65536 else None
        except ValueError:
            body = None
        if not isinstance(body, dict):
            return self._send(400, {"ok": False, "message": "the request is not a JSON object"})
        handler = {"/api/teach": self._teach, "/api/open": self._open,
                   "/api/upload": self._upload, "/api/capture": self._capture}.get(self.path)
        if handler is None:
            return self._send(404, {"ok": False, "message": f"no such action: {self.path}"})
        try:
            ok, msg = handler(body)
        except (KeyError, TypeError, ValueError) as e:
            ok, msg = False, f"bad request: {e}"
        self._send(200, {"ok": ok, "message": msg})

    def _teach(self, b):
        cam = b["camera"]
        if cam not in ("omni", "persp"):
            raise ValueError("camera must be omni or persp")
        return self.studio.seq.teach(int(b["index"]), cam, float(b["u"]), float(b["v"]))

    def _open(self, b):
        seq = self.studio.seq
        ok = seq.open(str(b["path"]))
        return ok, f"opened {seq.dir}" if ok else seq.error

    def _upload(self, _b):
        s = self.studio
        f = s.seq.summary()["lut_file"]
        if not f:
            return False, "nothing to upload: teach the ball first (or start with --lut FILE)"
        if not s.live or not s.live.connected:
            return False, ("no coprocessor connected" + (f": {s.live.error}" if s.live and
                                                          s.live.error else "") +
                           "; save the table and upload it later")
        err = s.live.upload_lut(Path(f).read_bytes())
        return err is None, err or f"uploaded {Path(f).name}: the coprocessor verified and uses it"

    def _capture(self, b):
        s = self.studio
        if not s.live or not s.live.connected:
            return False, "no coprocessor connected"
        pairs, mode = int(b.get("pairs", 1)), int(b.get("mode", commands.CAPTURE_QUARTER))
        if not 1 <= pairs <= 100 or mode not in (0, 1, 2):
            return False, "capture: pairs 1..100, mode 0 full, 1 half, 2 quarter"
        err = s.live.start_capture(pairs, mode)
        return err is None, err or f"capturing {pairs} pair(s)"


def serve(a):
    studio = Studio(a)
    Handler.studio = studio
    httpd = ThreadingHTTPServer((a.host, a.port), Handler)
    httpd.daemon_threads = True
    print(f"studio: http://{a.host}:{httpd.server_address[1]}/ (work folder {studio.work})",
          flush=True)
    try:
        httpd.serve_forever(poll_interval=0.2)
    except KeyboardInterrupt:
        pass
    finally:
        if studio.live:
            studio.live.stop = True
        httpd.server_close()
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link.studio", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("source", help="a sequence folder, a serial port or tcp:HOST:PORT")
    ap.add_argument("--calib", required=True, help="the rig calibration (JSON or blob)")
    ap.add_argument("--lut", help="colour table to start with (file or 'builtin')")
    ap.add_argument("--seq", help="with a link: a sequence to open as well")
    ap.add_argument("--ballvision", help="the ballvision program")
    ap.add_argument("--work", help="folder for processed frames (default: a new temp folder)")
    ap.add_argument("--host", default="127.0.0.1")
    ap.add_argument("--port", type=int, default=8765, help="HTTP port (0: any free one)")
    ap.add_argument("--baud", type=int, default=921600)
    a = ap.parse_args(argv)
    if not Path(a.calib).is_file():
        print(f"ballvision_link.studio: --calib {a.calib}: no such file", file=sys.stderr)
        return 2
    a.calib = os.path.abspath(a.calib)  # the ballvision runs may start elsewhere
    if a.lut and a.lut != "builtin":
        a.lut = os.path.abspath(a.lut)
    try:
        return serve(a)
    except OSError as e:
        print(f"ballvision_link.studio: cannot serve on {a.host}:{a.port}: {e}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
