#!/usr/bin/env bash
# Prints the exact guest instruction count per frame pair of the firmware in QEMU (TCG plugin
# firmware/tools/insncount.c between marker functions). Prints figures; asserts nothing about
# them. Exit 77 when the shared data is absent.
#   run_qemu_bench.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR COUNT PLUGIN NM [CALIB_JSON] [LUT_BLOB]
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 count=$6 plugin=$7 nm=$8 cal=${9:-} lut=${10:-}
fail() { echo "FAIL: $*"; exit 1; }
if [ ! -f "$src/frames.csv" ]; then echo "SKIP: $src not found"; exit 77; fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
[ -f "$plugin" ] || fail "plugin $plugin not built (target fw_insncount_plugin)"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --first 0 --count "$count" > /dev/null || fail "seq to-raw failed"
args="arg=seq=$work/seq"
if [ -n "$cal" ] && [ -f "$cal" ]; then
  "$bv" calib to-blob "$cal" "$work/calib.bin" > /dev/null || fail "calib to-blob $cal failed"
  args="$args,arg=cal=$work/calib.bin"
fi
[ -n "$lut" ] && [ -f "$lut" ] && args="$args,arg=lut=$lut"
addr() { "$nm" "$elf" | awk -v s="$1" '$3 == s { print "0x" $1 }'; }

run() {  # $1 begin marker, $2 end marker, $3 log [$4 semihosting args, default $args]
  "$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
    -serial "file:$work/uart.bin" -semihosting-config "enable=on,target=native,${4:-$args}" \
    -plugin "$plugin,begin=$(addr "$1"),end=$(addr "$2")" -d plugin -D "$3" \
    -kernel "$elf" < /dev/null 2> "$work/qemu.err" || { cat "$work/qemu.err"; fail "QEMU failed"; }
  grep '^insncount:' "$3" | tail -1
}
echo "firmware: $elf"
echo "sequence: $count frame pairs of $src (raw YUYV via ballvision seq to-raw)"
echo "calibration: ${cal:-none}, LUT: ${lut:-none}"
pipe=$(run bv_perf_begin bv_perf_end "$work/pipeline.log")
pair=$(run bv_pair_begin bv_pair_end "$work/pair.log")
echo "pipeline (Pipeline::Process) per frame pair: $pipe"
echo "whole loop per frame pair (pipeline + packet + UART + status): $pair"
# One camera at a time (the other column of frames.csv emptied): the pipeline with a single
# image, i.e. that camera's front end plus the one-camera fallback and the filter.
for cam in omni persp; do
  d="$work/seq_$cam"
  mkdir -p "$d" && ln -sf "$work"/seq/*.yuyv "$d"/
  awk -F, -v OFS=, -v cam="$cam" 'NR == 1 { print; next } { if (cam == "omni") $4 = ""; else $3 = ""; print }' \
    "$work/seq/frames.csv" > "$d/frames.csv"
  echo "pipeline per $cam image alone: $(run bv_perf_begin bv_perf_end "$work/$cam.log" "${args/seq=$work\/seq/seq=$d}")"
done
# Issue 11: the built-in colour model's table (no LUT stored), without and with online colour
# adaptation (refits every 16 confirmed pairs, the table rebuilt 2 of 64 rows per pair).
if [ -n "$cal" ] && [ -f "$cal" ]; then
  base="arg=seq=$work/seq,arg=cal=$work/calib.bin"
  echo "pipeline per frame pair, built-in colour table: $(run bv_perf_begin bv_perf_end "$work/builtin.log" "$base")"
  echo "pipeline per frame pair, built-in table + colour adaptation: $(run bv_perf_begin bv_perf_end "$work/adapt.log" "$base,arg=adapt=1")"
fi
if echo "$pipe" | grep -q 'intervals=0 '; then
  echo "note: the pipeline did not run (no valid calibration + LUT: BV_FW_CALIB_JSON and"
  echo "      BV_FW_LUT_BLOB); the loop figure then covers the no-calibration path only"
fi
echo "budget (DESIGN.md §5): <= 1500000 instructions per frame pair, full pipeline; <= 1200000"
echo "  including field features and localisation (the pipeline figure above includes them)"
# Latency from "pair complete and handed out by the camera" (bv_pair_begin) to "last byte of the
# ball-state packet queued for the UART" (bv_pair_end). -icount shift=0 runs 1 instruction per
# virtual ns; on the STM32H743 at 480 MHz it is instructions / 480 per us at IPC 1 (the M7
# dual-issues, caches and flash wait states move it either way: an estimate, not a measurement).
mean=$(echo "$pair" | sed -n 's/.*mean=\([0-9]*\).*/\1/p')
max=$(echo "$pair" | sed -n 's/.*max=\([0-9]*\).*/\1/p')
if [ -n "$mean" ] && [ -n "$max" ]; then
  awk -v m="$mean" -v x="$max" 'BEGIN { printf "latency frame complete -> last packet byte to UART: mean %.0f us, max %.0f us (QEMU virtual time); STM32H743 @ 480 MHz, IPC 1: mean %.2f ms, max %.2f ms\n", m / 1000, x / 1000, m / 480000, x / 480000 }'
fi
