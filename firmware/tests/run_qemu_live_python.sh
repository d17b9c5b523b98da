#!/usr/bin/env bash
# The main computer's Python decoder on a live stream: QEMU serves UART0 on a TCP socket
# (-chardev socket, the guest starts only once the client is connected) and
# `python3 -m ballvision_link tcp:...` decodes it while the firmware runs.
# Exit 0 pass, 1 fail, 77 skip (shared data absent).
#   run_qemu_live_python.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR COUNT PYTHON_PKG_DIR
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 count=$6 pydir=$7
fail() { echo "FAIL: $*"; exit 1; }
. "$(cd "$(dirname "$0")" && pwd)/qemu_link.sh"
[ -f "$src/frames.csv" ] || { echo "SKIP: $src not found"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --count "$count" > /dev/null || fail "seq to-raw failed"
qemu_socket "$qemu" "$elf" "$work" 60 "arg=seq=$work/seq" -icount shift=0
PYTHONPATH="$pydir" timeout 60 /usr/bin/python3 -m ballvision_link "tcp:127.0.0.1:$port" \
  --csv "$work/live.csv" > "$work/python.out" 2>&1
prc=$?
wait $qpid
qrc=$?
cat "$work/python.out"
[ $qrc -eq 0 ] || { cat "$work/qemu.err"; fail "QEMU exited with $qrc"; }
[ $prc -eq 0 ] || fail "python listener exited with $prc"
grep -Eq "^summary: ball_states=$count status=[1-9][0-9]* (other=[0-9]+ )?decoder_errors=0 " "$work/python.out" ||
  fail "expected $count ball states, status packets and no decoder errors"
diff <(tail -n +2 "$work/seq/frames.csv" | cut -d, -f2) <(tail -n +2 "$work/live.csv" | cut -d, -f2) \
  > /dev/null || fail "decoded t_us differ from the frames' t_us"
echo "PASS: python decoded $count live ball states from QEMU"
