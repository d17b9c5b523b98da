#!/usr/bin/env bash
# Issue 11: "the ball lies at pixel (u, v) of the persp camera" over UART0 makes the emulated
# board (calibration stored, no colour table: the built-in one) learn the ball colour from the
# next pair, store the table A/B with CRC and use it.
#   run_qemu_teach.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR PYTHON3
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 py=$6
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
if [ ! -f "$src/truth.csv" ]; then echo "SKIP: $src not found"; exit 77; fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
# Frame 1 thirty times: wherever in the replay the command arrives, the ball is at the click. (In
# frame 0 the ball hangs at the top of its drop against the hall, and the built-in look check
# refuses it until it moves: the pipeline acquires it from frame 1 on.)
"$bv" seq to-raw "$src" "$work/seq" --first 1 --count 1 > /dev/null || fail "seq to-raw failed"
{ echo "index,t_us,omni_file,persp_file"
  for i in $(seq 0 29); do echo "$i,$((i * 33333)),omni_1.yuyv,persp_1.yuyv"; done
} > "$work/seq/frames.csv"
repo=$(cd "$here/../.." && pwd)
"$bv" calib to-blob "$repo/host_tests/data/reference_rig_calib.json" "$work/cal.bin" > /dev/null ||
  fail "calib to-blob"
# The click: the persp ball centre of frame 1.
read -r u v < <(awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i }
                         NR == 3 { print $c["cu_persp"], $c["cv_persp"] }' "$src/truth.csv")
"$py" "$here/make_teach_commands.py" "$work/commands.bin" "$u" "$v" ||
  fail "make_teach_commands"
qemu_piped "$qemu" "$elf" "$work" "$work/uart.bin" "$work/commands.bin" \
  "arg=seq=$work/seq,arg=cal=$work/cal.bin"
"$py" "$here/check_teach_replies.py" "$work/uart.bin" || exit 1
echo "PASS: taught over UART0 at persp pixel ($u, $v): table stored and active"
