"""Fixed-seed fuzz loop for the Python decoder (ctest: python_decoder_fuzz). Mutates the
conformance corpus and random bytes for a bounded time and checks what must always hold: no
exception, every accepted message is well-formed, feeding in chunks gives the same result as
feeding at once, and the counters account for every delimiter.
    python3 fuzz_decoder.py [SECONDS] [SEED]"""
import json
import math
import os
import random
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
from ballvision_link import BallState, Decoder, StatusReport  # noqa: E402
from ballvision_link.protocol import MODES, MAX_PAYLOAD  # noqa: E402

CORPUS = os.path.join(os.path.dirname(__file__), "..", "..", "..", "host_tests", "data",
                      "protocol_conformance.json")


def mutate(rng, seeds):
    data = bytearray(rng.choice(seeds))
    for _ in range(rng.randint(1, 4)):
        op = rng.randrange(6)
        i = rng.randrange(len(data) + 1)
        if op == 0 and data:
            data[min(i, len(data) - 1)] ^= 1 << rng.randrange(8)
        elif op == 1:
            data[i:i] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
        elif op == 2:
            del data[i:i + rng.randint(1, 16)]
        elif op == 3:
            data += rng.choice(seeds)
        elif op == 4:
            data[i:i] = b"\x00"
        else:
            data = bytearray(rng.randrange(256) for _ in range(rng.randint(0, 3000)))
    return bytes(data)


def check(data, rng):
    whole = Decoder()
    msgs = whole.feed(data)
    assert isinstance(msgs, list)
    for m in msgs:
        if isinstance(m, BallState):
            assert m.mode in MODES and isinstance(m.found, bool)
            if m.found:
                assert all(math.isfinite(v) for v in (m.x, m.y, m.z, m.vx, m.vy, m.vz))
        elif isinstance(m, StatusReport):
            assert 0 <= m.calibration_state <= 2 and 0 <= m.lut_state <= 4
        else:
            assert len(m[2]) <= MAX_PAYLOAD
    chunked = Decoder()
    got, i = [], 0
    while i < len(data):
        n = rng.randint(1, 64)
        got += chunked.feed(data[i:i + n])
        i += n
    assert repr(got) == repr(msgs) and chunked.errors == whole.errors  # repr: NaN != NaN
    assert chunked.bytes_discarded == whole.bytes_discarded
    frames = whole.frames_ok + sum(v for k, v in whole.errors.items() if k != "payload")
    # Each delimiter ends at most one frame; an unterminated tail counts only if oversize.
    assert frames <= data.count(0) + 1, (frames, data.count(0))


def main():
    seconds = float(sys.argv[1]) if len(sys.argv) > 1 else 3.0
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 15
    rng = random.Random(seed)
    seeds = [bytes.fromhex(c["hex"]) for c in json.load(open(CORPUS))["cases"]]
    seeds = [s for s in seeds if s]
    end, n = time.monotonic() + seconds, 0
    while time.monotonic() < end:
        check(mutate(rng, seeds), rng)
        n += 1
    print(f"python decoder fuzz: {n} inputs, seed {seed}, {seconds:.0f} s, 0 failures")


if __name__ == "__main__":
    main()
