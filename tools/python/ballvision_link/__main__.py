"""python3 -m ballvision_link SOURCE [--csv OUT] [--status-csv OUT] [--pose-csv OUT]
                               [--lines-csv OUT] [--obstacles-csv OUT] [--goals-csv OUT]
                               [--plot] [--baud N]
                               [--seconds S]

SOURCE: a serial port (needs pyserial), a file of captured bytes, '-' for stdin, or
tcp:HOST:PORT. The CSV files have the same columns as `ballvision listen`'s; they are written
to a temporary file beside the target and renamed into place at the end (also on Ctrl-C or
SIGTERM, which print the summary and exit with 128 + the signal number).
"""
import argparse
import math
import signal
import socket
import sys
import time

from .protocol import (BallState, Decoder, Goals, LinePoints, Obstacles, Pose, POSE_STATES,
                       StatusReport, FLAG_HAS_BOUNCE, FLAG_HAS_PREDICTION, camera_check_text)
from .safe_write import SafeOutput

# Same columns as tools/ballvision/states_csv.cpp (StatesCsvHeader(true)) and cmd_listen.cpp.
STATES_HEADER = ("index,t_us,found,x,y,z,vx,vy,vz,mode,omni_u,omni_v,persp_u,persp_v,ray_gap,"
                 "t_bounce_us,proc_us,px,py,pz,sigma_x,sigma_y,sigma_z,psigma_x,psigma_y,psigma_z,"
                 "check_omni,check_persp,check_omni_deg,check_persp_deg")
STATUS_HEADER = ("seq,uptime_us,frames_processed,frame_rate_hz,frames_dropped,deadline_overruns,"
                 "packets_dropped,pairs_omni_missing,pairs_persp_missing,pairs_out_of_sync,"
                 "pairs_out_of_order,pairs_torn,calibration_id,lut_id,calibration_state,"
                 "lut_state,rx_errors,command_errors,pipeline_errors,last_proc_us,max_proc_us,"
                 "fault_flags,rx_overruns,rx_ring_full,rx_line_errors,feature_packets_dropped,"
                 "line_points_unsent,check_omni,check_persp,omni_faults,persp_faults,"
                 "pairs_omni_unusable,pairs_persp_unusable,change_omni_deg,change_persp_deg,"
                 "confidence_omni,confidence_persp")


class Interrupted(Exception):
    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum


def _on_signal(signum, _frame):
    signal.signal(signum, signal.SIG_DFL)  # a second signal ends the process at once
    raise Interrupted(signum)


def states_row(m: BallState) -> str:
    """One CSV row formatted exactly as StatesCsvRow does (printf %.5f / %.3f of the f32)."""
    def f(v, fmt="%.5f", ok=True):
        return fmt % v if ok else ""
    r = [str(m.seq), str(m.t_us), "1" if m.found else "0"]
    r += [f(v, ok=m.found) for v in (m.x, m.y, m.z, m.vx, m.vy, m.vz)]
    r.append(m.mode)
    for v in (m.omni_u, m.omni_v, m.persp_u, m.persp_v):
        r.append(f(v, "%.3f", v is not None))
    r.append(f(m.ray_gap, ok=m.ray_gap >= 0))  # NaN compares false, as in C++
    r.append(str(m.t_bounce_us) if m.flags & FLAG_HAS_BOUNCE else "")
    r.append(str(m.proc_us))
    r += [f(v, ok=bool(m.flags & FLAG_HAS_PREDICTION)) for v in (m.px, m.py, m.pz)]
    # sigmas in whole mm as the packet carries them, printed like C++ (m with 3 decimals)
    def mm(values, ok):
        return ["%d.%03d" % divmod(round(v * 1000), 1000) if ok else "" for v in values]
    r += mm((m.sigma_x, m.sigma_y, m.sigma_z), m.found)
    r += mm((m.psigma_x, m.psigma_y, m.psigma_z), bool(m.flags & FLAG_HAS_PREDICTION))
    r += [str(m.omni_check & 3), str(m.persp_check & 3)]
    r += ["%d.%02d" % divmod(round(v * 100), 100) for v in (m.omni_change_deg, m.persp_change_deg)]
    return ",".join(r) + "\n"


def status_row(st: StatusReport) -> str:
    """As cmd_listen.cpp's ostream output (a double prints like %g)."""
    vals = [st.seq, st.uptime_us, st.frames_processed, "%g" % st.frame_rate_hz,
            st.frames_dropped, st.deadline_overruns, st.packets_dropped, st.pairs_omni_missing,
            st.pairs_persp_missing, st.pairs_out_of_sync, st.pairs_out_of_order, st.pairs_torn,
            st.calibration_id, st.lut_id, st.calibration_state, st.lut_state, st.rx_errors,
            st.command_errors, st.pipeline_errors, st.last_proc_us, st.max_proc_us,
            st.fault_flags, st.rx_overruns, st.rx_ring_full, st.rx_line_errors,
            st.feature_packets_dropped, st.line_points_unsent, st.check_omni & 3,
            st.check_persp & 3, st.check_omni >> 2, st.check_persp >> 2, st.pairs_omni_unusable,
            st.pairs_persp_unusable, "%g" % st.change_omni_deg, "%g" % st.change_persp_deg,
            "%g" % st.confidence_omni, "%g" % st.confidence_persp]
    return ",".join(str(v) for v in vals) + "\n"


def _open_tcp(source: str):
    host, port = source[4:].rsplit(":", 1)
    for _ in range(50):  # QEMU may still be starting (as cmd_listen.cpp: 50 x 0.1 s)
        try:
            s = socket.create_connection((host, int(port)), timeout=5)
            break
        except OSError:
            time.sleep(0.1)
    else:
        raise SystemExit(f"cannot connect to {source}")
    s.settimeout(0.2)  # silence is not an end: wait (and honour --seconds) like the C++ one

    def read():
        try:
            return s.recv(4096)  # b"" only when the peer closed the connection
        except socket.timeout:
            return None
        except ConnectionResetError:  # a hang-up is an end of stream, as a close is
            return b""
    return read

POSE_COLUMNS = ["seq", "t_us", "state", "x", "y", "heading", "sigma_x", "sigma_y",
                "sigma_heading", "quality", "ambiguous", "hint_rejected", "usable", "points_used",
                "inliers"]
FIELD_HEADERS = {Pose: ",".join(POSE_COLUMNS),
                 LinePoints: "seq,t_us,found,index,x,y",
                 Obstacles: "seq,t_us,found,index,x,y,radius",
                 Goals: "seq,t_us,found,index,x,y,bearing,half_width,rays,post_rays,which,"
                        "which_ambiguous"}


def _csv_value(v) -> str:
    """As `ballvision listen` writes it (C++ stream: 6 significant digits, -1 not -1.0)."""
    return format(v, "g") if isinstance(v, float) else str(v)


def _field_rows(msg):
    """CSV rows of a pose / line-points / obstacles message (one row per point or obstacle)."""
    if isinstance(msg, Pose):  # state as its number and flags as 0/1, as `ballvision listen`
        row = [int(v) if isinstance(v, bool) else v for v in (getattr(msg, k) for k in POSE_COLUMNS)]
        row[2] = POSE_STATES.index(msg.state)
        return [row]
    if isinstance(msg, LinePoints):
        return [[msg.seq, msg.t_us, msg.found, i, x, y] for i, (x, y) in enumerate(msg.points)]
    if isinstance(msg, Goals):
        return [[msg.seq, msg.t_us, msg.found, i, *g[:7], int(g[7])] for i, g in enumerate(msg.goals)]
    return [[msg.seq, msg.t_us, msg.found, i, x, y, r] for i, (x, y, r) in enumerate(msg.obstacles)]


def _open(source: str, baud: int):
    """A read() returning bytes, None for "nothing yet" or b"" at the end of the source."""
    if source.startswith("tcp:"):
        return _open_tcp(source)
    if source.startswith("/dev/"):
        try:
            import serial  # pyserial, Debian python3-serial
        except ImportError:
            raise SystemExit("ballvision_link: reading a serial port needs pyserial "
                             "(apt install python3-serial, or pip install pyserial)")
        port = serial.Serial(source, baudrate=baud, timeout=0.2)
        return lambda: port.read(4096) or None
    f = sys.stdin.buffer if source == "-" else open(source, "rb")
    return lambda: f.read1(4096)  # what is there now: a pipe may stay open and quiet


def _non_negative(text: str) -> float:
    v = float(text)
    if not math.isfinite(v) or v < 0:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a number >= 0")
    return v


def _baud(text: str) -> int:
    v = int(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"got {text!r}, expected a positive integer")
    return v


class _Listener:
    def __init__(self, a):
        self.a = a
        self.dec = Decoder()
        self.balls = self.statuses = self.others = 0
        self.states = SafeOutput(a.csv) if a.csv else None
        self.status = SafeOutput(a.status_csv) if a.status_csv else None
        paths = {Pose: a.pose_csv, LinePoints: a.lines_csv, Obstacles: a.obstacles_csv,
                 Goals: a.goals_csv}
        self.field = {t: SafeOutput(p) if p else None for t, p in paths.items()}
        self.field_counts = {Pose: 0, LinePoints: 0, Obstacles: 0, Goals: 0}
        for t, out in self.field.items():
            if out:
                out.write(FIELD_HEADERS[t] + "\n")
        if self.states:
            self.states.write(STATES_HEADER + "\n")
        if self.status:
            self.status.write(STATUS_HEADER + "\n")
        self.plot = _make_plot() if a.plot else None

    def handle(self, msg):
        if isinstance(msg, BallState):
            self.balls += 1
            if self.states:
                self.states.write(states_row(msg))
            if self.plot and msg.found:
                _update_plot(self.plot, msg, self.balls)
        elif type(msg) in self.field:
            self.field_counts[type(msg)] += 1
            out = self.field[type(msg)]
            if out:
                for row in _field_rows(msg):
                    out.write(",".join(_csv_value(v) for v in row) + "\n")
        elif isinstance(msg, StatusReport):
            self.statuses += 1
            if self.status:
                self.status.write(status_row(msg))
            if not self.a.quiet:
                print(f"status: {msg.frames_processed} frames, {msg.frame_rate_hz:.1f} Hz, "
                      f"dropped {msg.frames_dropped}, overruns {msg.deadline_overruns}, "
                      f"rx lost: uart overrun {msg.rx_overruns}, ring full {msg.rx_ring_full}, "
                      f"line errors {msg.rx_line_errors}, feature packets dropped "
                      f"{msg.feature_packets_dropped}, line points unsent {msg.line_points_unsent}; "
                      f"cameras: omni {camera_check_text(msg.check_omni)} "
                      f"({msg.change_omni_deg:.2f} deg), persp {camera_check_text(msg.check_persp)} "
                      f"({msg.change_persp_deg:.2f} deg)")
        else:
            self.others += 1

    def finish(self) -> bool:
        ok = True
        for out in (self.states, self.status, *self.field.values()):
            if out is None:
                continue
            try:
                out.commit()
            except OSError as e:
                print(f"ballvision_link: {e}", file=sys.stderr)
                ok = False
        d = self.dec
        print(f"summary: ball_states={self.balls} status={self.statuses} other={self.others} "
              f"decoder_errors={sum(d.errors.values())} {d.errors} "
              f"bytes_discarded={d.bytes_discarded} pose={self.field_counts[Pose]} "
              f"lines={self.field_counts[LinePoints]} obstacles={self.field_counts[Obstacles]} "
              f"goals={self.field_counts[Goals]}")
        return ok


def _make_plot():
    import matplotlib.pyplot as plt
    plt.ion()
    fig, ax = plt.subplots()
    lines = {k: ax.plot([], [], label=k)[0] for k in "xyz"}
    ax.legend()
    ax.set_xlabel("t [s]")
    ax.set_ylabel("m")
    return (plt, ax, lines, {k: [] for k in "txyz"})


def _update_plot(plot, msg, n):
    plt, ax, lines, hist = plot
    for k, v in zip("txyz", (msg.t_us * 1e-6, msg.x, msg.y, msg.z)):
        hist[k].append(v)
    if n % 5 == 0:
        for k in "xyz":
            lines[k].set_data(hist["t"], hist[k])
        ax.relim()
        ax.autoscale_view()
        plt.pause(0.001)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link", description=__doc__)
    ap.add_argument("source")
    ap.add_argument("--csv", help="write ball states here")
    ap.add_argument("--status-csv", help="write status reports here")
    ap.add_argument("--pose-csv", help="write pose packets here")
    ap.add_argument("--lines-csv", help="write line points here (one row per point)")
    ap.add_argument("--obstacles-csv", help="write obstacles here (one row per obstacle)")
    ap.add_argument("--goals-csv", help="write goals here (one row per goal)")
    ap.add_argument("--plot", action="store_true", help="live matplotlib plot of x, y, z")
    ap.add_argument("--quiet", action="store_true", help="no per-status lines")
    ap.add_argument("--baud", type=_baud, default=921600)
    ap.add_argument("--seconds", type=_non_negative, default=0)
    a = ap.parse_args(argv)
    old = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _listen(a)
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _listen(a) -> int:
    try:
        listener = _Listener(a)
    except OSError as e:
        print(f"ballvision_link: {e}", file=sys.stderr)
        return 1
    except Interrupted as e:
        print("ballvision_link: interrupted before the first read", file=sys.stderr)
        return 128 + e.signum
    start, interrupted = time.monotonic(), None
    try:
        read = _open(a.source, a.baud)
        while not a.seconds or time.monotonic() - start < a.seconds:
            data = read()
            if data is None:
                continue
            if not data:
                break
            for msg in listener.dec.feed(data):
                listener.handle(msg)
    except Interrupted as e:
        interrupted = e.signum
    if interrupted:
        print(f"ballvision_link: interrupted by {signal.Signals(interrupted).name}; "
              "finishing with what was received", file=sys.stderr)
    written = listener.finish()
    if interrupted:
        return 128 + interrupted
    return 0 if written and listener.balls + listener.statuses else 1


if __name__ == "__main__":
    sys.exit(main())
