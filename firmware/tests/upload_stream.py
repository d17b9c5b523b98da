#!/usr/bin/env python3
"""The main computer's side of fw_qemu_upload_stream: uploads a blob over UART0 (QEMU serves it
on a TCP socket) the way `python3 -m ballvision_link.upload` does, one command at a time, each
acknowledged before the next, while the firmware keeps processing frame pairs. Any refused or
unanswered command fails the run: there are no retries.

  upload_stream.py --bytes TARGET BLOB           prints the upload's size on the wire
  upload_stream.py PORT TARGET BLOB MIN_FRAMES   runs it; TARGET is lut or calibration

After the commit's ack it reads to the end of the stream and checks the last status packet:
the blob active, no receive loss (rx_overruns, rx_ring_full, rx_line_errors, rx_errors) and no
refused command. MIN_FRAMES: ball states that must arrive while the upload is in progress; more
must follow its end (the whole upload overlapped frame processing)."""
import os
import socket
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tools", "python"))
from ballvision_link import commands  # noqa: E402
from ballvision_link.protocol import BallState, Decoder, StatusReport  # noqa: E402

FIRST_SEQ = 1000
REPLY_TIMEOUT_S = 20.0


def fail(msg):
    print(f"FAIL: {msg}")
    sys.exit(1)


def upload_frames(target_name, blob_path):
    target = commands.TARGET_LUT if target_name == "lut" else commands.TARGET_CALIBRATION
    return commands.upload(FIRST_SEQ, target, open(blob_path, "rb").read())


class Link:
    def __init__(self, port):
        deadline = time.monotonic() + 10.0
        while True:  # QEMU may not be listening yet
            try:
                self.sock = socket.create_connection(("127.0.0.1", port), timeout=REPLY_TIMEOUT_S)
                break
            except ConnectionRefusedError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.05)
        self.dec = Decoder()
        self.balls = 0
        self.statuses = []
        self.eof = False

    def read(self):
        """One read from the socket; returns the ack/error replies it completed."""
        try:
            data = self.sock.recv(65536)
        except socket.timeout:
            return None
        if not data:
            self.eof = True
            return []
        replies = []
        for msg in self.dec.feed(data):
            if isinstance(msg, BallState):
                self.balls += 1
            elif isinstance(msg, StatusReport):
                self.statuses.append(msg)
            elif isinstance(msg, tuple):
                replies.append(commands.parse_reply(msg[0], msg[2]))
        return replies

    def command(self, frame, seq):
        self.sock.sendall(frame)
        deadline = time.monotonic() + REPLY_TIMEOUT_S
        while time.monotonic() < deadline and not self.eof:
            for reply in self.read() or []:
                if reply is None or reply[1] != seq:
                    fail(f"unexpected reply {reply} to command seq {seq}")
                if reply[2] is not None:
                    fail(f"command seq {seq} refused: {reply[2]}")
                return
        fail(f"no reply to command seq {seq} (the firmware lost it)")


def main():
    if sys.argv[1] == "--bytes":
        print(sum(len(f) for f in upload_frames(sys.argv[2], sys.argv[3])))
        return 0
    port, target, blob, min_frames = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])
    frames = upload_frames(target, blob)
    link = Link(port)
    t0 = time.monotonic()
    balls_before = link.balls
    for i, frame in enumerate(frames):
        link.command(frame, FIRST_SEQ + i)
    during = link.balls - balls_before
    wall = time.monotonic() - t0
    balls_at_commit = link.balls
    while not link.eof:
        link.read()
    after = link.balls - balls_at_commit
    if not link.statuses:
        fail("no status packet")
    st = link.statuses[-1]
    print(f"upload: {len(frames)} commands ({sum(map(len, frames))} bytes) each acked on the "
          f"first try in {wall:.2f} s wall; ball states: {balls_before} before, {during} during, "
          f"{after} after the upload; decoder errors {sum(link.dec.errors.values())}")
    print(f"final status: frames_processed {st.frames_processed}, lut_state {st.lut_state}, "
          f"calibration_state {st.calibration_state}, rx_errors {st.rx_errors}, command_errors "
          f"{st.command_errors}, rx_overruns {st.rx_overruns}, rx_ring_full {st.rx_ring_full}, "
          f"rx_line_errors {st.rx_line_errors}, packets_dropped {st.packets_dropped}")
    state = st.lut_state if target == "lut" else st.calibration_state
    if state != 0:
        fail("the uploaded blob is not active")
    if (st.rx_errors, st.command_errors, st.rx_overruns, st.rx_ring_full,
            st.rx_line_errors) != (0, 0, 0, 0, 0):
        fail("receive loss or refused commands reported")
    if sum(link.dec.errors.values()) != 0:
        fail("corrupt frames from the firmware")
    if during < min_frames:
        fail(f"only {during} frame pairs were processed during the upload (< {min_frames})")
    if after == 0:
        fail("the frames ended before the upload did: it did not overlap frame processing")
    print("PASS: upload streamed while frames were processed, completed on the first try")
    return 0


if __name__ == "__main__":
    sys.exit(main())
