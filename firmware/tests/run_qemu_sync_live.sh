#!/usr/bin/env bash
# Clock sync with the running firmware: QEMU in real time (no -icount, so the board's clock
# follows the host's) serves UART0 on a TCP socket; `python3 -m ballvision_link.sync` sends
# requests at 20 Hz until the replay ends (or `ballvision sync` with TOOL=cpp). Every request
# the board read must be answered once, no reply refused as a fault (unknown id, echo mismatch,
# inconsistent stamps), no duplicate, the estimate never restarted. How many answers come late depends on the host's load, not on the
# firmware: the estimator setting them aside as outliers is its job, so they are counted as
# answered, not bounded. (Drift cannot be judged here: seconds of exchanges, ms jitter.)
#   run_qemu_sync_live.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR PYTHON_PKG_DIR [python|cpp]
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 pydir=$6 tool=${7:-python}
fail() { echo "FAIL: $*"; exit 1; }
. "$(cd "$(dirname "$0")" && pwd)/qemu_link.sh"
[ -f "$src/frames.csv" ] || { echo "SKIP: $src not found"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --count 3 > /dev/null || fail "seq to-raw failed"
# rx_bytes: the replay is held open until 54 requests (28 bytes each on the wire) arrived.
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
num() { echo "$final" | sed -n "s/.* $1 \([0-9]*\).*/\1/p"; }
sent=$(echo "$final" | sed -n 's/^final: sent \([0-9]*\),.*/\1/p')
acc=$(num accepted) out=$(num outliers)
[ -n "$sent" ] && [ -n "$acc" ] && [ -n "$out" ] || fail "cannot read: $final"
[ "$acc" -ge 20 ] || fail "only $acc exchanges accepted: too few for an estimate"
# The board reads 1500 bytes (rx_bytes) before it ends: 54 requests of 28 bytes; it answers all
# it read but perhaps the last (requests sent after that are never read, however many the load
# lets through before the tool sees the link close).
[ $(( acc + out )) -ge 52 ] || fail "$sent requests sent, only $(( acc + out )) answered"
echo "$final" | grep -Eq "restarts 0 duplicates 0 refused 0 outliers [0-9]+$" ||
  fail "restarted, duplicated or a reply refused as a fault"
echo "PASS: $(( acc + out )) of $sent clock sync requests answered by the live firmware ($out late)"
