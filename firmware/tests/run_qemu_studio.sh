#!/usr/bin/env bash
# Issue 16 item 3: the studio on a live link. The emulated board serves UART0 on a TCP socket and
# replays the sequence in a loop; the page (headless Chromium) shows its ball states, the top view
# and the status counters; when the board is killed the page says the link ended and the
# studio still answers. Screenshots in WORK/shots. Exit 0 pass, 1 fail, 77 skip.
# The page also uploads LUT_BLOB and the board's status then reports it in use.
#   run_qemu_studio.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR CALIB_JSON LUT_BLOB STUDIO_TEST
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 calib=$6 lut=$7 studio_test=$8
fail() { echo "FAIL: $*"; exit 1; }
. "$(cd "$(dirname "$0")" && pwd)/qemu_link.sh"
[ -f "$src/frames.csv" ] || { echo "SKIP: $src not found"; exit 77; }
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --count 30 > /dev/null || fail "seq to-raw failed"
# The 30 pairs over and over (t_us keeps rising) so the board outlives the page's checks.
awk -F, 'NR == 1 { print; next } { row[n++] = $0 }
         END { for (k = 0; k < 400; ++k) for (i = 0; i < n; ++i) {
                 split(row[i], f, ","); print k * n + i "," (k * n + i) * 33333 "," f[3] "," f[4] } }' \
  "$work/seq/frames.csv" > "$work/seq/frames.loop" && mv "$work/seq/frames.loop" "$work/seq/frames.csv"
"$bv" calib to-blob "$calib" "$work/cal.bin" > /dev/null || fail "calib to-blob"
# -icount: the board's clock (and its watchdog) counts instructions, so a loaded machine that
# starves QEMU does not look like a hung loop.
qemu_socket "$qemu" "$elf" "$work" 300 "arg=seq=$work/seq,arg=cal=$work/cal.bin" -icount shift=0
/usr/bin/python3 "$studio_test" --ballvision "$bv" --calib "$calib" --out "$work/shots" \
  --live "tcp:127.0.0.1:$port" --live-end "kill $qpid" --live-lut "$lut"
rc=$?
kill "$qpid" 2> /dev/null
wait "$qpid" 2> /dev/null
exit $rc
