#!/usr/bin/env bash
# Commands from the main computer reach the firmware through UART0's receive side: a status
# request is answered with a status packet, a valid parameter with an ack, an unknown one with
# an error reply; the loop keeps processing frames.
#   run_qemu_commands.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR PYTHON3
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 py=$6
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
if [ ! -f "$src/frames.csv" ]; then echo "SKIP: $src not found"; exit 77; fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --first 0 --count 3 > /dev/null || fail "seq to-raw failed"
repo=$(cd "$here/../.." && pwd)
"$bv" calib to-blob "$repo/host_tests/data/reference_rig_calib.json" "$work/cal.bin" > /dev/null ||
  fail "calib to-blob"
"$py" "$here/make_commands.py" "$work/commands.bin" "$work/cal.bin" || fail "make_commands"
chunks=$(( ($(stat -c %s "$work/cal.bin") + 511) / 512 ))
replies=$(( 2 + 1 + chunks + 1 ))  # two parameters, upload begin, chunks, commit
qemu_piped "$qemu" "$elf" "$work" "$work/uart.bin" "$work/commands.bin" "arg=seq=$work/seq"
"$bv" listen "$work/uart.bin" --csv "$work/states.csv" --status-csv "$work/status.csv" --quiet \
  > "$work/listen.out" 2>&1 || { cat "$work/listen.out"; fail "nothing decoded"; }
cat "$work/listen.out"
grep -q "ball_states=3 status=3 other=$replies " "$work/listen.out" ||
  fail "expected 3 ball states, 3 status packets (boot, requested, final) and $replies replies"
grep -q 'decoder_errors=0 ' "$work/listen.out" || fail "decoder errors"
# Booted without calibration; the uploaded one must be active at the end.
hdr=$(head -1 "$work/status.csv")
col() { local i; i=$(echo "$hdr" | tr , '\n' | grep -nx "$1" | cut -d: -f1); sed -n "$2p" "$work/status.csv" | cut -d, -f"$i"; }
[ "$(col calibration_state 2)" = 1 ] || fail "boot status should report the calibration missing"
[ "$(col calibration_state 4)" = 0 ] || fail "uploaded calibration not active at the end"
echo "PASS: commands and a $chunks-chunk calibration upload received over UART0 and answered"
