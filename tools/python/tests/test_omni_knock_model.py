"""tools/python/omni_knock_model.py: on ground maps made from a known turn and shift of the rays
it finds that turn and shift, and the rotation-only model is left with the shift's error."""
import os
import re
import subprocess
import sys
import tempfile
import unittest

import numpy as np

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "omni_knock_model.py")
H = 0.776


def ground_map(a_deg, b_deg, shift):
    """Floor points of a 480 x 640 'image': pixel (v, u) looks along azimuth and range as a
    radial layout does; the rays then turned (about x by a, y by b) and the points shifted."""
    v, u = np.mgrid[0:480, 0:640].astype(float)
    du, dv = u - 320, v - 240
    rho = np.hypot(du, dv)
    rng = 0.3 + 6.0 * (rho / 240.0) ** 2
    az = np.arctan2(dv, du)
    x, y = rng * np.cos(az), rng * np.sin(az)
    a, b = np.radians(a_deg), np.radians(b_deg)
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    rot = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]]) @ np.array(
        [[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    d = np.stack([x, y, -H * np.ones_like(x)], -1) @ rot.T
    t = H / np.maximum(-d[..., 2], 1e-3)
    return (d[..., 0] * t + shift[0]).astype(np.float32), (d[..., 1] * t + shift[1]).astype(
        np.float32)


class OmniKnockModelTest(unittest.TestCase):
    def test_a_known_turn_and_shift_are_found(self):
        with tempfile.TemporaryDirectory() as d:
            for name, a, b, shift in (("same", 0, 0, (0, 0)), ("knocked", 2.0, 3.0, (-0.05, 0.01))):
                os.makedirs(os.path.join(d, name))
                gx, gy = ground_map(a, b, shift)
                np.savez(os.path.join(d, name, "omni_ground_map.npz"), ground_x=gx, ground_y=gy)
            r = subprocess.run([sys.executable, SCRIPT, os.path.join(d, "knocked"),
                                os.path.join(d, "same")], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, r.stderr)
            lines = {l.split("  ")[0].strip(): l for l in r.stdout.splitlines()}
            full = lines["rotation+shift"]
            x, y = map(float, re.search(r"about x\s+([-\d.]+) deg, about y\s+([-\d.]+)", full).groups())
            self.assertAlmostEqual(x, 2.0, delta=0.05)
            self.assertAlmostEqual(y, 3.0, delta=0.05)
            sx, sy = map(float, re.search(r"shift ([-\d.]+) ([-\d.]+) m", full).groups())
            self.assertAlmostEqual(sx, -0.05, delta=0.003)
            self.assertAlmostEqual(sy, 0.01, delta=0.003)
            rms = lambda l: float(re.search(r"error rms ([\d.]+)", l).group(1))
            self.assertLess(rms(full), 0.002)
            self.assertGreater(rms(lines["rotation"]), rms(full))
            self.assertGreater(rms(lines["none (the calibration as it is)"]), rms(lines["rotation"]))


if __name__ == "__main__":
    unittest.main()
