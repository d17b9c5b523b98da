#!/usr/bin/env bash
# The same frames through the firmware in QEMU and through `ballvision run` on the host: the
# decoded ball states must agree (image centroids to 0.01 px, found/mode exactly, position to
# 5 mm, velocity to 0.05 m/s; float math differs slightly between newlib/ARM and glibc/x86).
#   run_qemu_vs_host.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR FIRST COUNT CALIB_JSON LUT_BLOB
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 first=$6 count=$7 calib=$8 lut=$9
fail() { echo "FAIL: $*"; exit 1; }
for f in "$src/frames.csv" "$calib" "$lut"; do
  [ -f "$f" ] || { echo "SKIP: $f not found"; exit 77; }
done
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --first "$first" --count "$count" > /dev/null || fail "seq to-raw failed"
"$bv" calib to-blob "$calib" "$work/calib.bin" || fail "calib to-blob failed"
"$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
  -serial "file:$work/uart.bin" \
  -semihosting-config "enable=on,target=native,arg=seq=$work/seq,arg=cal=$work/calib.bin,arg=lut=$lut" \
  -kernel "$elf" < /dev/null 2> "$work/qemu.err"
rc=$?
cat "$work/qemu.err"
[ $rc -eq 0 ] || fail "QEMU exited with $rc"
"$bv" listen "$work/uart.bin" --csv "$work/fw.csv" --status-csv "$work/status.csv" --quiet ||
  fail "nothing decoded"
"$bv" run "$work/seq" --calib "$calib" --lut "$lut" --out "$work/host.csv" || fail "host run failed"
last=$(tail -1 "$work/status.csv")
hdr=$(head -1 "$work/status.csv")
col() { local i; i=$(echo "$hdr" | tr , '\n' | grep -nx "$1" | cut -d: -f1); echo "$last" | cut -d, -f"$i"; }
echo "final status: $last"
[ "$(col calibration_state)" = 0 ] && [ "$(col lut_state)" = 0 ] || fail "calibration/LUT not loaded"
[ "$(col pipeline_errors)" = 0 ] || fail "pipeline errors on the device"
[ "$(col frames_processed)" = "$count" ] || fail "frames_processed != $count"
# Row by row (the listener's index column is the packet sequence number, the host's the frame
# index: compare from t_us on).
paste -d'|' <(tail -n +2 "$work/fw.csv") <(tail -n +2 "$work/host.csv") | awk -F'|' -v n="$count" '
  function abs(x) { return x < 0 ? -x : x }
  function near(a, b, tol) { return (a == "" && b == "") || (a != "" && b != "" && abs(a - b) <= tol) }
  {
    split($1, f, ","); split($2, h, ",");
    rows++
    if (f[2] != h[2] || f[3] != h[3] || f[10] != h[10]) { print "row " rows ": t_us/found/mode differ: " $0; bad++ }
    for (i = 4; i <= 6; i++) if (!near(f[i], h[i], 0.005)) { print "row " rows ": position col " i " " f[i] " vs " h[i]; bad++ }
    for (i = 7; i <= 9; i++) if (!near(f[i], h[i], 0.05)) { print "row " rows ": velocity col " i " " f[i] " vs " h[i]; bad++ }
    for (i = 11; i <= 14; i++) if (!near(f[i], h[i], 0.01)) { print "row " rows ": centroid col " i " " f[i] " vs " h[i]; bad++ }
    if (f[3] == 1) found++
  }
  END {
    if (rows != n) { print "rows: " rows " != " n; exit 1 }
    printf "compared %d states, ball found in %d, %d mismatches\n", rows, found, bad
    exit bad > 0 || found == 0
  }' || fail "firmware and host disagree"
echo "PASS: firmware in QEMU matches the host pipeline"
