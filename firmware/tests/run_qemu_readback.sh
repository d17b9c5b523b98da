#!/usr/bin/env bash
# Issue 11: the colour table in use read back from the running firmware with
# `ballvision readback` (command 0x2C, answers 0x0E). QEMU in real time serves UART0 on a TCP
# socket; the board boots with LUT, and the file written must be the stored table byte for byte.
#   run_qemu_readback.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR LUT
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 lut=$6
here=$(cd "$(dirname "$0")" && pwd)
fail() { echo "FAIL: $*"; exit 1; }
. "$here/qemu_link.sh"
for f in "$src/frames.csv" "$lut"; do
  [ -f "$f" ] || { echo "SKIP: $f not found"; exit 77; }
done
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --count 10 > /dev/null || fail "seq to-raw failed"
chunks=$(( ($(stat -c %s "$lut") + 511) / 512 ))
# rx_bytes: the replay is held open until every read (one per 512 bytes, 23 bytes each on the
# wire) arrived; each is answered in the iteration that reads it, before the last pairs play.
# -icount: the board's clock (and its watchdog) counts instructions, not the host's time.
qemu_socket "$qemu" "$elf" "$work" 60 "arg=seq=$work/seq,arg=lut=$lut,arg=rx_bytes=$(( chunks * 23 ))" \
  -icount shift=0
timeout 60 "$bv" readback "tcp:127.0.0.1:$port" --out "$work/table.lut" --seconds 30 \
  > "$work/readback.out" 2>&1
rrc=$?
wait $qpid
qrc=$?
cat "$work/readback.out"
[ $qrc -eq 0 ] || { cat "$work/qemu.err"; fail "QEMU exited with $qrc"; }
[ $rrc -eq 0 ] || fail "ballvision readback exited with $rrc"
cmp "$work/table.lut" "$lut" || fail "the table read back differs from the stored one"
echo "PASS: the table in use ($chunks chunks) read back over UART0 equals the stored table"
