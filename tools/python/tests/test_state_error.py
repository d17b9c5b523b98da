"""tools/python/state_error.py: the figures issue 40's notes quote (median, p90 of the last two
thirds), on a small hand-made sequence, and its refusals."""
import os
import subprocess
import sys
import tempfile
import unittest

SCRIPT = os.path.join(os.path.dirname(__file__), "..", "state_error.py")


def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


class StateErrorTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        d = self.dir.name
        with open(os.path.join(d, "truth.csv"), "w") as f:
            f.write("index,ball_x,ball_y,ball_z,ball_state\n")
            for i in range(9):
                f.write(f"{i},0,{i},0.11,roll\n")
        # Frame i's state is off by i cm in x; frame 4 has none.
        self.states = os.path.join(d, "states.csv")
        with open(self.states, "w") as f:
            f.write("index,found,x,y,z,check_omni,check_persp\n")
            for i in range(9):
                f.write(f"{i},{0 if i == 4 else 1},{i / 100},{i},0.11,0,0\n")

    def tearDown(self):
        self.dir.cleanup()

    def test_last_two_thirds(self):
        r = run(self.states, self.dir.name)
        self.assertEqual(r.returncode, 0, r.stderr)
        # 8 frames with a state; the last 6 (2, 3, 5, 6, 7, 8 cm): median 6, p90 rank 4 -> 7.
        self.assertIn("8 frames with a state; frames 2-8 (6): median 6.0 cm, p90 7.0 cm", r.stdout)

    def test_all_frames_and_per_frame_lines(self):
        r = run(self.states, self.dir.name, "--skip-fraction", "0", "--frames")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("frames 0-8 (8): median 5.0 cm", r.stdout)
        self.assertIn("\n8 8.0 roll 0 0", r.stdout)

    def test_refusals_name_what_is_wrong(self):
        r = run(self.states, os.path.join(self.dir.name, "missing"))
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("truth.csv", r.stderr)
        r = run(self.states, self.dir.name, "--skip-fraction", "1")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("--skip-fraction", r.stderr)
        with open(self.states, "a") as f:
            f.write("99,1,0,0,0.11,0,0\n")
        r = run(self.states, self.dir.name)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("frame 99", r.stderr)


if __name__ == "__main__":
    unittest.main()
