#!/usr/bin/env bash
# Capture over the link from the emulated board: a capture request for every pair (full size,
# both cameras) and a clock sync request reach UART0's receive side; `ballvision capture`
# turns the recorded stream into a sequence. The captured images must equal the board's
# frames byte for byte, with their exposure times, and `ballvision run` on the capture must
# give exactly the ball states it gives on the original frames. A stream cut in half gives a
# valid partial sequence that says it is partial.
#   run_qemu_capture.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR FIRST COUNT CALIB_JSON LUT PYTHON3
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 first=$6 count=$7 calib=$8 lut=$9 py=${10}
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
capture_inputs "$bv" "$src" "$work" "$first" "$count" "$calib" "$lut"
PYTHONPATH="$here/../../tools/python" "$py" -c "
import sys
from ballvision_link import commands
out = commands.clock_sync(1, 7, 1700000000000000)
out += commands.capture_start(2, $count, commands.CAPTURE_FULL, 3)
out += commands.capture_start(3, 1)  # while the first runs: refused, busy
open(sys.argv[1], 'wb').write(out)" "$work/commands.bin" || fail "commands"
# capture_chunks=4000: QEMU's UART takes bytes instantly, so a whole pair is streamed in one
# loop iteration and the capture holds consecutive pairs (on the board the 921600 Bd line sets
# the pace).
qemu_piped "$qemu" "$elf" "$work" "$work/uart.bin" "$work/commands.bin" \
  "arg=seq=$work/seq,arg=cal=$work/calib.bin,arg=lut=$lut,arg=capture_chunks=4000"

"$bv" capture "$work/uart.bin" --out "$work/cap" > "$work/capture.out" 2>&1 ||
  { cat "$work/capture.out"; fail "capture did not complete"; }
cat "$work/capture.out"
grep -q "pairs_written=$count of $count" "$work/capture.out" || fail "expected $count pairs"
grep -q '"complete": true' "$work/cap/capture.json" || fail "capture.json does not say complete"
# Same images, same exposure times, in order.
paste -d, <(tail -n +2 "$work/seq/frames.csv") <(tail -n +2 "$work/cap/frames.csv") |
  while IFS=, read -r _ t o p _ tc oc pc; do
    [ "$t" = "$tc" ] || fail "exposure time $tc, expected $t"
    cmp -s "$work/seq/$o" "$work/cap/$oc" || fail "$oc differs from $o"
    cmp -s "$work/seq/$p" "$work/cap/$pc" || fail "$pc differs from $p"
  done || exit 1
[ "$(tail -n +2 "$work/cap/frames.csv" | wc -l)" = "$count" ] || fail "frames.csv rows"
# The board's clock sync reply (t2 <= t3, t1 echoed) and the second request refused as busy.
PYTHONPATH="$here/../../tools/python" "$py" -c "
import sys
from ballvision_link import Decoder, ClockSyncReply, commands
r = [m for m in Decoder().feed(open(sys.argv[1], 'rb').read()) if isinstance(m, ClockSyncReply)]
assert len(r) == 1 and r[0].id == 7 and r[0].t1_host_us == 1700000000000000, r
assert r[0].t2_rx_us <= r[0].t3_tx_us, r
print('clock sync reply:', r[0])
e = [m for m in Decoder().feed(open(sys.argv[1], 'rb').read())
     if isinstance(m, tuple) and m[0] == commands.MSG_ERROR]
assert len(e) == 1 and commands.parse_reply(e[0][0], e[0][2])[2].startswith('busy'), e" "$work/uart.bin" || fail "clock sync reply"

# Replay: identical ball states (all columns but the host's processing time).
"$bv" run "$work/seq" --calib "$calib" --lut "$lut" --out "$work/orig.csv" > /dev/null ||
  fail "run on the original frames"
"$bv" run "$work/cap" --calib "$calib" --lut "$lut" --out "$work/cap.csv" > /dev/null ||
  fail "run on the captured sequence"
strip() { awk -F, -v OFS=, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "proc_us") c = i }
                            { if (c) $c = ""; print }' "$1"; }
diff <(strip "$work/orig.csv") <(strip "$work/cap.csv") > "$work/diff.txt" ||
  { head "$work/diff.txt"; fail "ball states differ between the original and the capture"; }
found=$(awk -F, 'NR > 1 && $3 == 1' "$work/cap.csv" | wc -l)
[ "$found" -gt 0 ] || fail "no ball found: the comparison would prove nothing"
echo "replay: $count ball states identical ($found with the ball found)"

# Cut off half way: the complete pairs form a valid sequence that says it is partial.
head -c $(( $(stat -c %s "$work/uart.bin") / 2 )) "$work/uart.bin" > "$work/half.bin"
"$bv" capture "$work/half.bin" --out "$work/part" > "$work/part.out" 2>&1
rc=$?
cat "$work/part.out"
[ $rc -eq 1 ] || fail "a cut-off capture must exit 1 (got $rc)"
grep -q '"complete": false' "$work/part/capture.json" || fail "partial capture.json"
grep -q '"note": "cut off: the stream ended before the capture' "$work/part/capture.json" ||
  fail "capture.json must say it was cut off"
grep -q "incomplete: the stream ended after" "$work/part.out" || fail "the broken pair named"
rows=$(tail -n +2 "$work/part/frames.csv" | wc -l)
[ "$rows" -ge 1 ] && [ "$rows" -lt "$count" ] || fail "partial rows: $rows"
"$bv" run "$work/part" --calib "$calib" --lut "$lut" --out "$work/part.csv" > /dev/null ||
  fail "the partial sequence does not replay"
head -n $(( rows + 1 )) <(strip "$work/cap.csv") | diff - <(strip "$work/part.csv") > /dev/null ||
  fail "the partial sequence's ball states differ from the first $rows of the whole"
echo "PASS: $count pairs captured over UART0, byte-identical, identical replay; cut-off capture keeps $rows valid pairs"
