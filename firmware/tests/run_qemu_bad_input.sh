#!/usr/bin/env bash
# Bad camera input must be counted and reported, never crash the firmware: a frames.csv with a
# malformed row, an overlong row, a missing frame file and a wrong-size frame file.
#   run_qemu_bad_input.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5
fail() { echo "FAIL: $*"; exit 1; }
if [ ! -f "$src/frames.csv" ]; then echo "SKIP: $src not found"; exit 77; fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --first 0 --count 2 > /dev/null || fail "seq to-raw failed"
csv="$work/seq/frames.csv"
omni=$(sed -n 2p "$csv" | cut -d, -f3)
persp=$(sed -n 2p "$csv" | cut -d, -f4)
head -c 1000 /dev/zero > "$work/seq/short.yuyv"
{
  echo "5,200000,not-a-number"                                   # malformed: 3 columns
  echo "6,x300000,$omni,$persp"                                  # malformed: t_us
  printf '7,%s,%s,%s\n' 400000 "$(head -c 300 /dev/zero | tr '\0' a).yuyv" "$persp"  # overlong
  echo "8,500000,omni/missing.yuyv,$persp"                       # omni file missing -> persp only
  echo "9,600000,$omni,short.yuyv"                               # persp wrong size -> omni only
  echo "10,700000,$omni,$persp"                                  # good again
} >> "$csv"
"$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
  -serial "file:$work/uart.bin" -semihosting-config "enable=on,target=native,arg=seq=$work/seq" \
  -kernel "$elf" < /dev/null 2> "$work/qemu.err"
rc=$?
cat "$work/qemu.err"
[ $rc -eq 0 ] || fail "QEMU exited with $rc"
"$bv" listen "$work/uart.bin" --csv "$work/states.csv" --status-csv "$work/status.csv" --quiet \
  > "$work/listen.out" 2>&1 || { cat "$work/listen.out"; fail "nothing decoded"; }
cat "$work/listen.out"
# 2 good rows + row 8 (persp only) + row 9 (omni only) + row 10 = 5 ball states.
grep -q 'ball_states=5 ' "$work/listen.out" || fail "expected 5 ball-state packets"
grep -q 'decoder_errors=0 ' "$work/listen.out" || fail "decoder errors"
hdr=$(head -1 "$work/status.csv"); last=$(tail -1 "$work/status.csv")
col() { local i; i=$(echo "$hdr" | tr , '\n' | grep -nx "$1" | cut -d: -f1); echo "$last" | cut -d, -f"$i"; }
echo "final status: $last"
[ "$(col frames_processed)" = 5 ] || fail "frames_processed $(col frames_processed) != 5"
[ "$(col pairs_omni_missing)" = 1 ] || fail "pairs_omni_missing $(col pairs_omni_missing) != 1"
[ "$(col pairs_persp_missing)" = 1 ] || fail "pairs_persp_missing $(col pairs_persp_missing) != 1"
[ $(( $(col fault_flags) & 2 )) -ne 0 ] || fail "fault_flags lacks kFaultCameraBadInput (2)"
for what in "malformed row" "line too long" "cannot open frame file" "not 640x480x2"; do
  grep -q "$what" "$work/qemu.err" || fail "diagnostic '$what' missing"
done
echo "PASS: bad rows and frames counted, the loop kept running"
