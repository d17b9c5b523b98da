"""python3 -m ballvision_link.teach against a fake coprocessor on TCP: the teach command's bytes,
the ack after "the next pair", a refusal named, silence."""
import os
import socket
import struct
import subprocess
import sys
import threading
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))
from ballvision_link import commands  # noqa: E402
from ballvision_link.protocol import Decoder, encode_frame  # noqa: E402


def fake_device(answer):
    """Serves one connection: reads the teach command, then answers with `answer(cmd)` (bytes or
    None for silence). Returns the address and a list the received command is put in."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(1)
    got = []

    def run():
        c, _ = srv.accept()
        dec = Decoder()
        while not got:
            data = c.recv(4096)
            if not data:
                break
            got.extend(m for m in dec.feed(data) if isinstance(m, tuple))
        reply = answer(got[0]) if got else None
        if reply:
            c.sendall(encode_frame(0x01, 1, b"\0" * 3) + reply)  # other traffic first
        c.recv(1)  # until the tool hangs up
        c.close()
        srv.close()
    threading.Thread(target=run, daemon=True).start()
    return f"tcp:127.0.0.1:{srv.getsockname()[1]}", got


def teach(port, *args):
    return subprocess.run([sys.executable, "-m", "ballvision_link.teach", port, *args],
                          env=dict(os.environ, PYTHONPATH=os.path.join(HERE, "..")),
                          capture_output=True, text=True, timeout=30)


class TeachTest(unittest.TestCase):
    def test_ack_after_the_pair(self):
        port, got = fake_device(lambda m: encode_frame(
            commands.MSG_ACK, 2, struct.pack("<BI", commands.TEACH_BALL, m[1])))
        r = teach(port, "--persp", "318", "236")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("taught", r.stdout)
        self.assertEqual(got[0][0], commands.TEACH_BALL)
        self.assertEqual(got[0][2], struct.pack("<Bff", commands.TEACH_PERSP_PIXEL, 318, 236))

    def test_refusal_is_named(self):
        port, _ = fake_device(lambda m: encode_frame(
            commands.MSG_ERROR, 2, struct.pack("<BIBI", commands.TEACH_BALL, m[1], 16, 1)))
        r = teach(port, "--floor", "1.5", "0")
        self.assertEqual(r.returncode, 1)
        self.assertIn("refused: the taught colour would take the field (detail 1); the old table "
                      "stays", r.stderr)

    def test_silence_times_out(self):
        port, _ = fake_device(lambda m: None)
        r = teach(port, "--omni", "40", "40", "--timeout", "0.5")
        self.assertEqual(r.returncode, 1)
        self.assertIn("no answer within 0.5 s; the old table stays", r.stderr)


if __name__ == "__main__":
    unittest.main()
