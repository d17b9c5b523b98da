#!/usr/bin/env bash
# A calibration upload streamed over UART0 while the firmware processes frame pairs at its full
# rate (the replay hands out the next pair as soon as the loop asks; the full pipeline runs):
# every command must be acknowledged on the first try, frame pairs must be processed before and
# after the upload completes, and the final status must report no receive loss. UART0 is a TCP
# socket (the guest starts once the client is connected); firmware/tests/upload_stream.py is
# the main computer. QEMU feeds UART0 slowly (~5 KB/s of wall time), so the sequence is replayed
# REPEAT times (same frame files, later timestamps) to outlast the upload.
#   run_qemu_upload_stream.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR CALIB_JSON LUT_BLOB MIN_FRAMES
#                             REPEAT
# Exit 0 pass, 1 fail, 77 skip (shared data absent).
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 calib=$6 lut=$7 min_frames=$8 repeat=$9
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
[ -f "$src/frames.csv" ] || { echo "SKIP: $src not found"; exit 77; }
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
[ -f "$calib" ] && [ -f "$lut" ] || fail "calibration $calib or LUT $lut missing"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" > /dev/null || fail "seq to-raw failed"
csv="$work/seq/frames.csv"
awk -F, -v OFS=, -v r="$repeat" 'NR == 1 { print; next } { row[++n] = $0 }
  END { split(row[n], last, ","); span = last[2] + 33333
        for (k = 0; k < r; k++) for (i = 1; i <= n; i++) {
          $0 = row[i]; $1 = k * n + i - 1; $2 += k * span; print } }' "$csv" > "$csv.new" &&
  mv "$csv.new" "$csv" || fail "repeating the sequence"
"$bv" calib to-blob "$calib" "$work/calib.bin" > /dev/null || fail "calib to-blob failed"
bytes=$(/usr/bin/python3 "$here/upload_stream.py" --bytes calibration "$work/calib.bin") ||
  fail "upload size"
# rx_bytes: the replay ends only after the loop has read the whole upload.
qemu_socket "$qemu" "$elf" "$work" 120 \
  "arg=seq=$work/seq,arg=cal=$work/calib.bin,arg=lut=$lut,arg=rx_bytes=$bytes" -icount shift=0
timeout 120 /usr/bin/python3 "$here/upload_stream.py" "$port" calibration "$work/calib.bin" \
  "$min_frames" \
  > "$work/upload.out" 2>&1
prc=$?
wait $qpid
qrc=$?
cat "$work/upload.out"
[ $qrc -eq 0 ] || { cat "$work/qemu.err"; fail "QEMU exited with $qrc"; }
[ $prc -eq 0 ] || fail "upload client exited with $prc"
