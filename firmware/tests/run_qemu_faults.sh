#!/usr/bin/env bash
# Fault injection in the firmware loop (issue 7): one fault per run, the loop must survive it
# (QEMU exits 0 at the end of the sequence), keep its deadline and report the fault.
#   run_qemu_faults.sh QEMU ELF BALLVISION SRC_SEQ WORK_DIR KIND [CALIB_JSON LUT_BLOB]
# KIND: torn | drop | swap | jump | stopcam | frozencam | uartstuck | hang. torn, drop, uartstuck and hang
# (the loop stops iterating: the board's watchdog must end the run with exit 103) are injected
# by the board (inject=, firmware/boards/qemu_mps2/board.cpp); swap, jump and stopcam are written into the
# test's frames.csv, which is exactly what the camera layer would see; frozencam (the omni
# camera serves one frame again and again) too. With CALIB_JSON and
# LUT_BLOB the full pipeline runs on the faulty frames (else the loop runs "not ready").
# Exit 0 pass, 1 fail, 77 skip (shared data absent).
set -u
qemu=$1 elf=$2 bv=$3 src=$4 work=$5 kind=$6 calib=${7:-} lut=${8:-}
period_us=33333
fail() { echo "FAIL [$kind]: $*"; exit 1; }
if [ ! -f "$src/frames.csv" ]; then echo "SKIP: $src not found"; exit 77; fi
[ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"

count=10 inject=""
case $kind in
  torn) inject=torn@3 ;;
  drop) inject=drop@3 ;;
  swap | jump | stopcam | frozencam) ;;
  uartstuck) count=40 inject=uartstuck@2 ;;
  hang) inject=hang@3 ;;  # enough packets to fill the 2 KB TX ring
  *) fail "unknown kind" ;;
esac

rm -rf "$work" && mkdir -p "$work"
"$bv" seq to-raw "$src" "$work/seq" --first 0 --count "$count" > /dev/null || fail "seq to-raw failed"
csv="$work/seq/frames.csv"
# Rows are numbered from 0 below (line 1 of frames.csv is the header).
case $kind in
  swap)  # rows 4 and 5 arrive in swapped exposure order
    awk -F, -v OFS=, 'NR == 6 { t5 = $2 } { line[NR] = $0; t[NR] = $2 }
      END { for (i = 1; i <= NR; i++) { $0 = line[i];
              if (i == 6) $2 = t[7]; else if (i == 7) $2 = t[6]; print } }' \
      "$csv" > "$csv.new" ;;
  jump)  # the clock jumps 2 s forward from row 5 on
    awk -F, -v OFS=, 'NR >= 7 { $2 += 2000000 } { print }' "$csv" > "$csv.new" ;;
  stopcam)  # the perspective camera delivers nothing from row 4 on
    awk -F, -v OFS=, 'NR >= 6 { $4 = "" } { print }' "$csv" > "$csv.new" ;;
  frozencam)  # the omni camera serves row 3's frame from row 3 on
    awk -F, -v OFS=, 'NR == 5 { f = $3 } NR > 5 { $3 = f } { print }' "$csv" > "$csv.new" ;;
esac
[ -f "$csv.new" ] && mv "$csv.new" "$csv"

args="arg=seq=$work/seq"
[ -n "$inject" ] && args="$args,arg=inject=$inject"
if [ -n "$calib" ] && [ -f "$calib" ] && [ -f "$lut" ]; then
  "$bv" calib to-blob "$calib" "$work/calib.bin" > /dev/null || fail "calib to-blob failed"
  args="$args,arg=cal=$work/calib.bin,arg=lut=$lut"
fi
"$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
  -serial "file:$work/uart.bin" -semihosting-config "enable=on,target=native,$args" \
  -kernel "$elf" < /dev/null 2> "$work/qemu.err"
rc=$?
echo "--- firmware diagnostics (semihosting stderr) ---"; cat "$work/qemu.err"
if [ "$kind" = hang ]; then
  [ $rc -eq 103 ] || fail "QEMU exited with $rc, expected 103 (watchdog)"
  grep -q '^WATCHDOG: the main loop stopped feeding' "$work/qemu.err" || fail "no watchdog diagnostic"
  "$bv" listen "$work/uart.bin" --csv "$work/states.csv" --quiet > "$work/listen.out" 2>&1 ||
    { cat "$work/listen.out"; fail "nothing decoded"; }
  cat "$work/listen.out"
  # Pairs 0..3 were sent (pair 3's packet goes out before the hung release), nothing after.
  grep -q 'ball_states=4 ' "$work/listen.out" || fail "expected the 4 ball states before the hang"
  echo "PASS [hang]: the watchdog caught the hung loop, exit 103"
  exit 0
fi
[ $rc -eq 0 ] || fail "QEMU exited with $rc (100 = fault, 101 = assert)"
grep -q '^firmware: done' "$work/qemu.err" || fail "the loop did not reach the end of the sequence"
board() { sed -n "s/^board: exit $1=\([0-9]*\)$/\1/p" "$work/qemu.err"; }
[ "$(board pairs_served)" -ge 1 ] || fail "no board exit summary"
# The board's own view of the deadline: every pair released within one frame period.
hold=$(board max_hold_us)
[ "$hold" -gt 0 ] && [ "$hold" -lt $period_us ] || fail "board max_hold_us $hold not in (0, $period_us)"

"$bv" listen "$work/uart.bin" --csv "$work/states.csv" --status-csv "$work/status.csv" --quiet \
  > "$work/listen.out" 2>&1 || { cat "$work/listen.out"; fail "nothing decoded"; }
cat "$work/listen.out"
summary=$(grep '^summary:' "$work/listen.out")
field() { echo "$summary" | sed -n "s/.*\b$1=\([0-9]*\).*/\1/p"; }
[ "$(field decoder_errors)" = 0 ] || fail "decoder errors in the UART stream"
[ "$(field bad_payloads)" = 0 ] || fail "payloads that do not parse"
hdr=$(head -1 "$work/status.csv")
last=$(tail -1 "$work/status.csv")
col() { local i; i=$(echo "$hdr" | tr , '\n' | grep -nx "$1" | cut -d: -f1); echo "$last" | cut -d, -f"$i"; }
echo "last status: $last"
# The fault must not cost the deadline (a stuck UART holds back every later status packet:
# there the board's max_hold_us above is the evidence).
max_proc=n/a
if [ "$kind" != uartstuck ]; then
  [ "$(col deadline_overruns)" = 0 ] || fail "deadline_overruns $(col deadline_overruns)"
  max_proc=$(col max_proc_us)
  [ "$max_proc" -gt 0 ] && [ "$max_proc" -lt $period_us ] || fail "max_proc_us $max_proc not in (0, $period_us)"
  [ "$(col pipeline_errors)" = 0 ] || fail "pipeline_errors $(col pipeline_errors)"
fi
expect() {  # expect COLUMN VALUE: the last status packet's column
  [ "$(col "$1")" = "$2" ] || fail "$1 = $(col "$1"), expected $2"
  echo "ok: $1 = $2"
}
states_t() { tail -n +2 "$work/states.csv" | cut -d, -f2; }
rows_t() { tail -n +2 "$csv" | cut -d, -f2; }

case $kind in
  torn)
    expect frames_processed $count; expect pairs_torn 1; expect frames_dropped 0
    [ "$(board pairs_torn)" = 1 ] || fail "board pairs_torn $(board pairs_torn)"
    diff <(rows_t) <(states_t) > /dev/null || fail "ball-state t_us differ from the frames'" ;;
  drop)  # row 3's omni and persp frames are overwritten by row 4's before the loop polls
    expect frames_processed $((count - 1)); expect frames_dropped 2; expect pairs_torn 0
    diff <(rows_t | sed 4d) <(states_t) > /dev/null || fail "ball-state t_us: row 3 not the one dropped" ;;
  swap)
    expect frames_processed $count; expect pairs_out_of_order 1
    diff <(rows_t) <(states_t) > /dev/null || fail "ball-state t_us differ from the frames'" ;;
  jump)
    expect frames_processed $count; expect pairs_out_of_order 0
    [ $(( $(col fault_flags) & 8 )) -ne 0 ] || fail "fault_flags $(col fault_flags) lacks kFaultTimestampJump (8)"
    echo "ok: fault_flags $(col fault_flags) has kFaultTimestampJump"
    diff <(rows_t) <(states_t) > /dev/null || fail "ball-state t_us differ from the frames'" ;;
  stopcam)
    expect frames_processed $count; expect pairs_persp_missing $((count - 4)); expect pairs_omni_missing 0
    diff <(rows_t) <(states_t) > /dev/null || fail "ball-state t_us differ from the frames'" ;;
  frozencam)
    # Rows 4-6 repeat row 3 (refused); the third repeat flags the camera unusable (state 3,
    # fault bit 0 repeated): rows 6-9. The persp camera is untouched.
    expect frames_processed $count; expect check_omni 3; expect omni_faults 1
    expect pairs_omni_unusable $((count - 6)); expect check_persp 0; expect pairs_persp_unusable 0
    sc() { tail -n +2 "$work/states.csv" | cut -d, -f"$(head -1 "$work/states.csv" | tr , '\n' | grep -nx "$1" | cut -d: -f1)" | tr '\n' ' '; }
    [ "$(sc check_omni)" = "0 0 0 0 0 0 3 3 3 3 " ] || fail "states.csv check_omni: $(sc check_omni)"
    echo "ok: states.csv check_omni $(sc check_omni)" ;;
  uartstuck)
    # Nothing after pair 2 reaches the wire: the stream stops mid-run, the loop does not block.
    refused=$(board uart_writes_refused)
    [ "$(board pairs_served)" = $count ] || fail "board pairs_served $(board pairs_served) != $count"
    [ "$refused" -gt 0 ] || fail "no packet refused by the stalled UART"
    [ "$(board uart_bytes_queued)" -gt 0 ] || fail "TX ring empty although stalled"
    [ "$(field ball_states)" -le 3 ] || fail "$(field ball_states) ball states got out after the stall"
    [ "$(wc -c < "$work/uart.bin")" = "$(board uart_bytes_sent)" ] ||
      fail "uart.bin size differs from the board's uart_bytes_sent"
    echo "ok: $refused packets refused, $(board uart_bytes_queued) bytes stuck in the ring" ;;
esac
echo "PASS [$kind]: exit 0, max_proc_us $max_proc, board max_hold_us $hold"
