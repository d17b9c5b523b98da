"""The shared conformance corpus (host_tests/data/protocol_conformance.json, also run by
host_tests/protocol_conformance_test.cpp against core/protocol): same verdicts, same counters."""
import json
import os
import sys
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from ballvision_link import BallState, Decoder, StatusReport, MSG_BALL_STATE, MSG_STATUS  # noqa

CORPUS = os.path.join(os.path.dirname(__file__), "..", "..", "..", "host_tests", "data",
                      "protocol_conformance.json")


def run(data: bytes, chunk: int):
    dec = Decoder()
    msgs = []
    for i in range(0, len(data), chunk):
        msgs += dec.feed(data[i:i + chunk])
    seen = []
    for m in msgs:
        if isinstance(m, BallState):
            seen.append([MSG_BALL_STATE, m.seq])
        elif isinstance(m, StatusReport):
            seen.append([MSG_STATUS, m.seq])
        else:
            seen.append([m[0], m[1]])
    e = dec.errors
    counters = {"frames_ok": dec.frames_ok, "crc": e["crc"], "cobs": e["cobs"],
                "oversize": e["oversize"], "short": e["short"], "version": e["version"],
                "length": e["length"], "bytes_discarded": dec.bytes_discarded,
                "bad_payload": e["payload"]}
    return seen, counters


class ConformanceTest(unittest.TestCase):
    def test_corpus(self):
        cases = json.load(open(CORPUS))["cases"]
        self.assertGreaterEqual(len(cases), 20)
        for c in cases:
            data = bytes.fromhex(c["hex"])
            for chunk in (1, 7, len(data) or 1):  # verdicts must not depend on read sizes
                with self.subTest(case=c["name"], chunk=chunk):
                    seen, counters = run(data, chunk)
                    self.assertEqual(seen, c["messages"])
                    self.assertEqual(counters, c["expect"])

    def test_feed_returns_everything_even_if_not_iterated(self):
        data = bytes.fromhex(json.load(open(CORPUS))["cases"][0]["hex"])
        dec = Decoder()
        dec.feed(data)  # result ignored: the frame is still decoded and counted
        self.assertEqual(dec.frames_ok, 1)
        got = dec.feed(data * 3)
        self.assertIsInstance(got, list)
        self.assertEqual(len(got), 3)


if __name__ == "__main__":
    unittest.main()
