#!/usr/bin/env bash
# Runs the firmware image in QEMU on a few frames of a captured sequence and checks the UART
# stream on the host. Exit 0 pass, 1 fail, 77 skip (shared data absent).
#   run_qemu_seq.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR COUNT [CAL_FILE EXPECTED_CAL_STATE]
# CAL_FILE: a file put into the calibration slot ("none": no file); EXPECTED_CAL_STATE: the
# calibration_state the status packets must report (0 ok, 1 missing, 2 corrupt).
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 count=$6 cal=${7:-none} want_cal_state=${8:-1}

fail() { echo "FAIL: $*"; exit 1; }

if [ ! -f "$src/frames.csv" ]; then
  echo "SKIP: sequence $src not found (shared data absent)"
  exit 77
fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first (cmake --build --preset host --target ballvision)"

rm -rf "$work" && mkdir -p "$work" || fail "cannot create $work"
"$bv" seq to-raw "$src" "$work/seq" --first 0 --count "$count" > "$work/to-raw.log" 2>&1 ||
  { cat "$work/to-raw.log"; fail "ballvision seq to-raw failed"; }

args="arg=seq=$work/seq"
[ "$cal" != none ] && args="$args,arg=cal=$cal"
# -icount shift=0: deterministic virtual time (1 instruction = 1 ns), so timings repeat exactly.
"$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
  -serial "file:$work/uart.bin" \
  -semihosting-config "enable=on,target=native,$args" \
  -kernel "$elf" < /dev/null > "$work/qemu.out" 2> "$work/qemu.err"
rc=$?
echo "--- firmware diagnostics (semihosting stderr) ---"; cat "$work/qemu.err"
[ $rc -eq 0 ] || fail "QEMU exited with $rc (100 = fault, 101 = assert)"

"$bv" listen "$work/uart.bin" --csv "$work/states.csv" --status-csv "$work/status.csv" --quiet \
  > "$work/listen.out" 2>&1 || { cat "$work/listen.out"; fail "ballvision listen found nothing"; }
cat "$work/listen.out"
summary=$(grep '^summary:' "$work/listen.out")
field() { echo "$summary" | sed -n "s/.*\b$1=\([0-9]*\).*/\1/p"; }
[ "$(field ball_states)" = "$count" ] || fail "expected $count ball-state packets, got $(field ball_states)"
[ "$(field status)" -ge 2 ] || fail "expected a boot and a final status packet"
[ "$(field decoder_errors)" = 0 ] || fail "decoder errors in the UART stream"
[ "$(field seq_gaps)" = 0 ] || fail "packet sequence numbers have gaps"
[ "$(field bad_payloads)" = 0 ] || fail "payloads that do not parse"

# One state per frame, with the frame's exposure time, in order.
diff <(tail -n +2 "$work/seq/frames.csv" | cut -d, -f2) <(tail -n +2 "$work/states.csv" | cut -d, -f2) \
  > /dev/null || fail "ball-state t_us do not match the frames' t_us"

# The final status packet: every frame processed, nothing dropped, counters sane.
hdr=$(head -1 "$work/status.csv")
last=$(tail -1 "$work/status.csv")
col() { local i; i=$(echo "$hdr" | tr , '\n' | grep -nx "$1" | cut -d: -f1); echo "$last" | cut -d, -f"$i"; }
echo "final status: $last"
[ "$(col frames_processed)" = "$count" ] || fail "frames_processed $(col frames_processed) != $count"
for c in frames_dropped packets_dropped pairs_omni_missing pairs_persp_missing pairs_out_of_sync \
         pairs_out_of_order pairs_torn pipeline_errors deadline_overruns; do
  [ "$(col $c)" = 0 ] || fail "$c = $(col $c), expected 0"
done
[ "$(col calibration_state)" = "$want_cal_state" ] ||
  fail "calibration_state $(col calibration_state), expected $want_cal_state"
max_proc=$(col max_proc_us)
[ "$max_proc" -gt 0 ] && [ "$max_proc" -lt 33333 ] || fail "max_proc_us $max_proc not in (0, 33333)"
echo "PASS: $count frames, $(field status) status packets, max_proc_us $max_proc"
