"""python3 -m ballvision_link SOURCE [--csv OUT] [--pose-csv OUT] [--lines-csv OUT]
                               [--obstacles-csv OUT] [--plot] [--baud N] [--seconds S]

SOURCE: a serial port (needs pyserial), a file of captured bytes, or tcp:HOST:PORT.
"""
import argparse
import csv
import socket
import sys
import time

from .protocol import BallState, Decoder, LinePoints, Obstacles, Pose, POSE_STATES, StatusReport

POSE_COLUMNS = ["seq", "t_us", "state", "x", "y", "heading", "sigma_x", "sigma_y",
                "sigma_heading", "quality", "ambiguous", "hint_rejected", "usable", "points_used",
                "inliers"]


def _csv(path, header):
    if not path:
        return None
    w = csv.writer(open(path, "w", newline=""))
    w.writerow(header)
    return w


def _field_rows(msg):
    """CSV rows of a pose / line-points / obstacles message (one row per point or obstacle)."""
    if isinstance(msg, Pose):  # state as its number and flags as 0/1, as `ballvision listen`
        row = [int(v) if isinstance(v, bool) else v for v in (getattr(msg, k) for k in POSE_COLUMNS)]
        row[2] = POSE_STATES.index(msg.state)
        return [row]
    if isinstance(msg, LinePoints):
        return [[msg.seq, msg.t_us, msg.found, i, x, y] for i, (x, y) in enumerate(msg.points)]
    return [[msg.seq, msg.t_us, msg.found, i, x, y, r] for i, (x, y, r) in enumerate(msg.obstacles)]


def _open(source: str, baud: int):
    if source.startswith("tcp:"):
        host, port = source[4:].rsplit(":", 1)
        for _ in range(50):
            try:
                s = socket.create_connection((host, int(port)), timeout=5)
                return lambda: s.recv(4096)
            except OSError:
                time.sleep(0.1)
        raise SystemExit(f"cannot connect to {source}")
    if source.startswith("/dev/"):
        import serial  # pyserial, Debian python3-serial
        port = serial.Serial(source, baudrate=baud, timeout=0.2)
        return lambda: port.read(4096)
    f = open(source, "rb")
    return lambda: f.read(4096)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link", description=__doc__)
    ap.add_argument("source")
    ap.add_argument("--csv", help="write ball states here")
    ap.add_argument("--pose-csv", help="write pose packets here")
    ap.add_argument("--lines-csv", help="write line points here (one row per point)")
    ap.add_argument("--obstacles-csv", help="write obstacles here (one row per obstacle)")
    ap.add_argument("--plot", action="store_true", help="live matplotlib plot of x, y, z")
    ap.add_argument("--baud", type=int, default=921600)
    ap.add_argument("--seconds", type=float, default=0)
    a = ap.parse_args(argv)
    read = _open(a.source, a.baud)
    dec = Decoder()
    writer = None
    if a.csv:
        out = open(a.csv, "w", newline="")
        writer = csv.writer(out)
        writer.writerow(["seq", "t_us", "found", "x", "y", "z", "vx", "vy", "vz", "mode",
                         "ray_gap", "t_bounce_us"])
    field = {Pose: _csv(a.pose_csv, POSE_COLUMNS),
             LinePoints: _csv(a.lines_csv, ["seq", "t_us", "found", "index", "x", "y"]),
             Obstacles: _csv(a.obstacles_csv, ["seq", "t_us", "found", "index", "x", "y",
                                               "radius"])}
    counts = {Pose: 0, LinePoints: 0, Obstacles: 0}
    plot = None
    if a.plot:
        import matplotlib.pyplot as plt
        plt.ion()
        fig, ax = plt.subplots()
        lines = {k: ax.plot([], [], label=k)[0] for k in "xyz"}
        ax.legend()
        ax.set_xlabel("t [s]")
        ax.set_ylabel("m")
        plot = (plt, fig, ax, lines, {k: [] for k in "txyz"})
    balls = statuses = 0
    start = time.monotonic()
    while not a.seconds or time.monotonic() - start < a.seconds:
        data = read()
        if not data:
            if a.source.startswith("/dev/"):
                continue
            break
        for msg in dec.feed(data):
            if isinstance(msg, BallState):
                balls += 1
                if writer:
                    writer.writerow([msg.seq, msg.t_us, int(msg.found), msg.x, msg.y, msg.z,
                                     msg.vx, msg.vy, msg.vz, msg.mode, msg.ray_gap,
                                     msg.t_bounce_us if msg.t_bounce_us is not None else ""])
                if plot and msg.found:
                    plt, fig, ax, lines, hist = plot
                    for k, v in zip("txyz", (msg.t_us * 1e-6, msg.x, msg.y, msg.z)):
                        hist[k].append(v)
                    if balls % 5 == 0:
                        for k in "xyz":
                            lines[k].set_data(hist["t"], hist[k])
                        ax.relim()
                        ax.autoscale_view()
                        plt.pause(0.001)
            elif type(msg) in field:
                counts[type(msg)] += 1
                if field[type(msg)]:
                    field[type(msg)].writerows(_field_rows(msg))
            elif isinstance(msg, StatusReport):
                statuses += 1
                print(f"status: {msg.frames_processed} frames, {msg.frame_rate_hz:.1f} Hz, "
                      f"dropped {msg.frames_dropped}, overruns {msg.deadline_overruns}, "
                      f"rx lost: uart overrun {msg.rx_overruns}, ring full {msg.rx_ring_full}, "
                      f"line errors {msg.rx_line_errors}, feature packets dropped "
                      f"{msg.feature_packets_dropped}, line points unsent {msg.line_points_unsent}")
    errs = sum(dec.errors.values())
    print(f"summary: ball_states={balls} status={statuses} decoder_errors={errs} "
          f"pose={counts[Pose]} lines={counts[LinePoints]} obstacles={counts[Obstacles]} "
          f"{dec.errors}")
    return 0 if balls + statuses else 1


if __name__ == "__main__":
    sys.exit(main())
