#!/usr/bin/env python3
"""The C++ estimator (`ballvision sync --exchanges`) and the Python one (ballvision_link.
clock_sync) on the same exchanges — jitter, queued replies, a coprocessor reset, an outlier —
give the same verdicts, offsets and drifts.   clock_sync_cross_test.py BALLVISION"""
import os
import random
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tools", "python"))
from ballvision_link.clock_sync import ClockSync  # noqa: E402
from ballvision_link.protocol import ClockSyncReply  # noqa: E402

BV = sys.argv.pop(1) if len(sys.argv) > 1 else "build/host/tools/ballvision"


def exchanges(seed, n=400):
    rng = random.Random(seed)
    host0, dev0, ppm = 1_700_000_000_000_000, 3e6, rng.uniform(-80, 80)
    rows = []
    for i in range(n):
        t = i * 1e5
        if i == n // 2:  # reset: the coprocessor's clock restarts near zero
            dev0, ppm = 2000 - t * (1 + ppm * 1e-6), rng.uniform(-80, 80)
        out = 150 + rng.uniform(0, 125) + rng.expovariate(1 / 80)
        back = 150 + rng.uniform(0, 1000) + (rng.uniform(0, 10000) if rng.random() < 0.2 else 0)
        t2 = dev0 + (t + out) * (1 + ppm * 1e-6)
        t3 = t2 + rng.uniform(0, 1500)
        if i == n // 4:
            t2 += 30000  # an outlier: held, then dropped
            t3 += 30000
        t4 = t + out + (t3 - t2) + back
        rows.append((i + 1, host0 + int(t), int(t2), int(t3), host0 + int(t4)))
    return rows


class CrossCheck(unittest.TestCase):
    def test_same_numbers(self):
        for seed in (1, 2, 3):
            rows = exchanges(seed)
            with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
                f.write("id,t1,t2,t3,t4\n")
                f.writelines(",".join(map(str, r)) + "\n" for r in rows)
            try:
                r = subprocess.run([BV, "sync", "--exchanges", f.name], capture_output=True,
                                   text=True)
            finally:
                os.unlink(f.name)
            self.assertEqual(r.returncode, 0, r.stderr)
            cpp = [line.split(",") for line in r.stdout.splitlines()]
            self.assertEqual(len(cpp), len(rows))
            py = ClockSync()
            verdicts = []
            for (rid, t1, t2, t3, t4), (cid, cverdict, coff, cdrift) in zip(rows, cpp):
                py.request_sent(rid, t1)
                v = py.reply(ClockSyncReply(0, rid, t1, t2, t3), t4)
                verdicts.append(v)
                self.assertEqual((int(cid), cverdict), (rid, v), f"seed {seed} exchange {rid}")
                self.assertLessEqual(abs(int(coff) - py.to_host_time(t2)), 1)  # rounding
                self.assertAlmostEqual(float(cdrift), py.drift_ppm, delta=1e-5)
            self.assertEqual(verdicts.count("restarted"), 1, f"seed {seed}")
            self.assertEqual(verdicts.count("held"), 2, f"seed {seed}: outlier and reset")

    def test_bad_file(self):
        with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
            f.write("id,t1,t2,t3,t4\n1,2,3\n")
        r = subprocess.run([BV, "sync", "--exchanges", f.name], capture_output=True, text=True)
        os.unlink(f.name)
        self.assertEqual(r.returncode, 1)
        self.assertIn(":2: expected 5 columns id,t1,t2,t3,t4", r.stderr)


if __name__ == "__main__":
    unittest.main()
