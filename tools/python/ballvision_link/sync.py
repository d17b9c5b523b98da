"""python3 -m ballvision_link.sync PORT [--hz 10] [--seconds S] [--baud N]

Runs the clock-sync exchange with the coprocessor (docs/protocol.md, "Clock sync") and prints,
once a second, the estimated offset (this computer's time.monotonic_ns clock minus the
coprocessor's, µs), drift (ppm), the smallest path delay seen and the exchange counts.
PORT: a serial port (pyserial) or tcp:HOST:PORT. In a program, use ClockSync the same way:
request_sent() before writing a request, reply() with each ClockSyncReply, then
to_host_time(msg.t_us) for every packet."""
import argparse
import socket
import sys
import time

from . import commands
from .clock_sync import ClockSync
from .protocol import ClockSyncReply, Decoder


def now_us() -> int:
    return time.monotonic_ns() // 1000


class _Link:
    def __init__(self, source: str, baud: int):
        if source.startswith("tcp:"):
            host, _, port = source[4:].rpartition(":")
            self._sock = socket.create_connection((host, int(port)), timeout=5)
            self._sock.settimeout(0.01)
            self.read, self.write = self._read_sock, self._write_sock
        else:
            try:
                import serial  # pyserial (Debian python3-serial)
            except ImportError:
                raise SystemExit("ballvision_link.sync: a serial port needs pyserial "
                                 "(apt install python3-serial, or pip install pyserial)")
            port = serial.Serial(source, baudrate=baud, timeout=0.01)
            self.read, self.write = lambda: port.read(4096), port.write

    def _write_sock(self, data: bytes) -> None:
        try:
            self._sock.sendall(data)
        except (BrokenPipeError, ConnectionResetError):
            raise EOFError("the coprocessor closed the connection")

    def _read_sock(self) -> bytes:
        try:
            data = self._sock.recv(4096)
        except socket.timeout:
            return b""
        except ConnectionResetError:  # the board exited with our last request unread
            raise EOFError("the coprocessor closed the connection")
        if not data:
            raise EOFError("the coprocessor closed the connection")
        return data


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python3 -m ballvision_link.sync", description=__doc__)
    ap.add_argument("port")
    ap.add_argument("--hz", type=float, default=10.0)
    ap.add_argument("--seconds", type=float, default=0.0, help="0: until Ctrl-C")
    ap.add_argument("--baud", type=int, default=921600)
    a = ap.parse_args(argv)
    if not 0.1 <= a.hz <= 100:
        ap.error("--hz must be 0.1..100")
    link, dec, sync = _Link(a.port, a.baud), Decoder(), ClockSync(baud=a.baud)
    start = last_print = time.monotonic()
    next_req, rid = start, 0
    try:
        while a.seconds <= 0 or time.monotonic() - start < a.seconds:
            if time.monotonic() >= next_req:
                rid += 1
                t1 = now_us()
                sync.request_sent(rid, t1)
                link.write(commands.clock_sync(rid, rid, t1))
                next_req += 1.0 / a.hz
            for msg in dec.feed(link.read()):
                if isinstance(msg, ClockSyncReply):
                    sync.reply(msg, now_us())
            if time.monotonic() - last_print >= 1.0:
                last_print = time.monotonic()
                _report(sync, rid, "")
    except KeyboardInterrupt:
        pass
    except EOFError as e:
        print(f"ballvision_link.sync: {e}", file=sys.stderr)
    _report(sync, rid, "final: ")
    return 0 if sync.valid else 1


def _report(sync: ClockSync, sent: int, prefix: str) -> None:
    if not sync.valid:
        print(f"{prefix}sent {sent}, no reply yet", flush=True)
        return
    c = sync.counts
    print(f"{prefix}sent {sent}, offset {sync.offset_us(0) / 1e6:.6f} s at t=0, drift {sync.drift_ppm:+.2f} "
          f"ppm, min delay {sync.min_delay_us:.0f} us, accepted {c['accepted']} held "
          f"{c['held']} restarts {c['restarted']} duplicates {c['duplicate']} refused "
          f"{c['unknown id'] + c['mismatch'] + c['inconsistent']} outliers {c['rejected']}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
