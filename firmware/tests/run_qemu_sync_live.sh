#!/usr/bin/env bash
# Clock sync with the running firmware: QEMU in real time (no -icount, so the board's clock
# follows the host's) serves UART0 on a TCP socket; `python3 -m ballvision_link.sync` sends
# requests at 20 Hz until the replay ends (or `ballvision sync` with TOOL=cpp). Every request must be answered once (the last two
# may be in flight when the board exits), at most 2 replies refused, the estimate never restarted.
# (Drift cannot be judged here: a few seconds of exchanges with millisecond jitter.)
#   run_qemu_sync_live.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR PYTHON_PKG_DIR [python|cpp]
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 pydir=$6 tool=${7:-python}
fail() { echo "FAIL: $*"; exit 1; }
. "$(cd "$(dirname "$0")" && pwd)/qemu_link.sh"
[ -f "$src/frames.csv" ] || { echo "SKIP: $src not found"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --count 3 > /dev/null || fail "seq to-raw failed"
# rx_bytes: the replay is held open until ~60 requests (each >= 25 bytes on the wire) arrived.
qemu_socket "$qemu" "$elf" "$work" 60 "arg=seq=$work/seq,arg=rx_bytes=1500"
if [ "$tool" = cpp ]; then
  timeout 60 "$bv" sync "tcp:127.0.0.1:$port" --hz 20 --seconds 30 > "$work/sync.out" 2>&1
else
  PYTHONPATH="$pydir" timeout 60 /usr/bin/python3 -m ballvision_link.sync \
    "tcp:127.0.0.1:$port" --hz 20 --seconds 30 > "$work/sync.out" 2>&1
fi
prc=$?
wait $qpid
qrc=$?
cat "$work/sync.out"
[ $qrc -eq 0 ] || { cat "$work/qemu.err"; fail "QEMU exited with $qrc"; }
[ $prc -eq 0 ] || fail "the sync tool exited with $prc"
final=$(grep '^final: ' "$work/sync.out") || fail "no final estimate"
acc=$(echo "$final" | sed -n 's/.*accepted \([0-9]*\).*/\1/p')
sent=$(echo "$final" | sed -n 's/^final: sent \([0-9]*\),.*/\1/p')
[ "${acc:-0}" -ge 50 ] || fail "only ${acc:-0} exchanges accepted"
[ $(( ${sent:-0} - acc )) -le 2 ] || fail "$sent requests sent, only $acc answered"
# Real-time QEMU on a busy host delays a reply now and then by tens of ms: the estimator refusing
# such an outlier is it working. More than two, a duplicate or a restart is a fault.
echo "$final" | grep -Eq "restarts 0 duplicates 0 refused [012]$" ||
  fail "restarted, duplicated or more than 2 refused replies"
echo "PASS: $acc of $sent clock sync requests answered by the live firmware"
