#!/usr/bin/env bash
# Capture mode 3 ("scanlines") from the emulated board: the firmware streams, per camera, the
# samples of the scan tables its pipeline runs on; `ballvision capture --calib` builds the same
# tables on the host from the calibration file (it refuses a stream whose sample count or
# positions CRC differ: the host's table is the device's, bit for bit) and puts the samples in
# place. Every sample must equal the board's frame at its pixel (Y, and its pair's U and V),
# every other pixel the fill; the sequence must replay with `ballvision run` (its ball output
# is not expected to match: attention and region growing read fill).
#   run_qemu_capture_scan.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR FIRST COUNT CALIB_JSON LUT PYTHON3
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 first=$6 count=$7 calib=$8 lut=$9 py=${10}
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
capture_inputs "$bv" "$src" "$work" "$first" "$count" "$calib" "$lut"
PYTHONPATH="$here/../../tools/python" "$py" -c "
import sys
from ballvision_link import commands
out = commands.capture_start(1, $count, commands.CAPTURE_SCANLINES, 3)
open(sys.argv[1], 'wb').write(out)" "$work/commands.bin" || fail "commands"
qemu_piped "$qemu" "$elf" "$work" "$work/uart.bin" "$work/commands.bin" \
  "arg=seq=$work/seq,arg=cal=$work/calib.bin,arg=lut=$lut,arg=capture_chunks=4000"

"$bv" capture "$work/uart.bin" --out "$work/cap" --calib "$calib" > "$work/capture.out" 2>&1 ||
  { cat "$work/capture.out"; fail "scanline capture did not complete"; }
cat "$work/capture.out"
grep -q "pairs_written=$count of $count" "$work/capture.out" || fail "expected $count pairs"
grep -q '"mode": "scanlines"' "$work/cap/capture.json" || fail "capture.json mode"
grep -q '"complete": true' "$work/cap/capture.json" || fail "capture.json does not say complete"
"$py" - "$work/seq" "$work/cap" <<'PY' || fail "samples differ from the board's frames"
import csv, json, os, sys
seq, cap = sys.argv[1], sys.argv[2]
meta = json.load(open(os.path.join(cap, "capture.json")))
fill = meta["fill_yuv"]
orig = list(csv.DictReader(open(os.path.join(seq, "frames.csv"))))
got = list(csv.DictReader(open(os.path.join(cap, "frames.csv"))))
assert len(got) == len(orig), (len(got), len(orig))
for cam, key in ((0, "omni"), (1, "persp")):
    mask = open(os.path.join(cap, "scan_mask_%s.pgm" % key), "rb").read()[-640 * 480:]
    real = [i for i in range(640 * 480) if mask[i]]
    n = meta["scanline_samples"][key]
    assert len(real) == n and n > 1000, (key, len(real), n)
    pair_real = set(i // 2 for i in real)
    for o, g in zip(orig, got):
        assert o["t_us"] == g["t_us"], (o, g)
        a = open(os.path.join(seq, o[key + "_file"]), "rb").read()
        b = open(os.path.join(cap, g[key + "_file"]), "rb").read()
        assert len(b) == 640 * 480 * 2
        bad = sum(1 for i in real if b[2 * i] != a[2 * i] or
                  b[4 * (i // 2) + 1] != a[4 * (i // 2) + 1] or b[4 * (i // 2) + 3] != a[4 * (i // 2) + 3])
        assert bad == 0, (key, g[key + "_file"], bad, "samples differ")
        is_real = bytearray(640 * 480)
        for i in real:
            is_real[i] = 1
        off = sum(1 for i in range(640 * 480) if not is_real[i] and b[2 * i] != fill[0])
        off += sum(1 for m in range(640 * 240) if m not in pair_real and
                   (b[4 * m + 1] != fill[1] or b[4 * m + 3] != fill[2]))
        assert off == 0, (key, off, "pixels off the table are not fill")
    print("%s: %d samples equal the board's frames in %d pairs, every other pixel fill"
          % (key, n, len(got)))
PY
"$bv" run "$work/cap" --calib "$calib" --lut "$lut" --out "$work/cap.csv" > /dev/null ||
  fail "ballvision run cannot read the scanline capture"
[ "$(tail -n +2 "$work/cap.csv" | wc -l)" = "$count" ] || fail "replay rows"
echo "PASS: $count scanline pairs over UART0, samples at the host table's pixels equal the frames"
