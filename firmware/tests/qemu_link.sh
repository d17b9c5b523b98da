# Sourced by the run_qemu_*.sh scripts that talk to the board's UART0 receive side.
#
#   qemu_piped QEMU ELF WORK OUT IN SEMIHOSTING_ARGS
# runs the emulated board with UART0 on a pipe chardev (FIFOs WORK/uart.in, WORK/uart.out): the
# bytes of IN reach its receive side (paced, below), what it sends lands in OUT. rx_bytes holds
# the replay open until the firmware has read every byte of IN. QEMU's stderr is WORK/qemu.err; a non-zero exit
# prints it and fails the test (the caller's fail()).
qemu_piped() {
  local qemu=$1 elf=$2 work=$3 out=$4 in=$5 args=$6 reader writer rc
  rm -f "$work/uart.in" "$work/uart.out"
  mkfifo "$work/uart.in" "$work/uart.out" || fail "mkfifo"
  cat "$work/uart.out" > "$out" & reader=$!
  # IN in pieces of half the board's 2 KB receive ring, 0.3 s apart: written at once, a larger IN
  # (fw_qemu_commands' 2,693 bytes) sometimes filled the ring before the loop drained it; the board
  # drops a frame then (by design, counted) and rx_bytes waited for it until the test's timeout.
  { local off size
    size=$(stat -c %s "$in")
    for ((off = 0; off < size; off += 1024)); do
      ((off > 0)) && sleep 0.3
      dd if="$in" bs=1024 skip=$((off / 1024)) count=1 status=none
    done
  } > "$work/uart.in" & writer=$!
  "$qemu" -machine mps2-an500 -display none -monitor none -icount shift=0 \
    -chardev "pipe,id=u0,path=$work/uart" -serial chardev:u0 \
    -semihosting-config "enable=on,target=native,$args,arg=rx_bytes=$(stat -c %s "$in")" \
    -kernel "$elf" < /dev/null 2> "$work/qemu.err"
  rc=$?
  kill "$writer" 2> /dev/null
  wait "$reader"
  [ $rc -eq 0 ] || { cat "$work/qemu.err"; fail "QEMU exited with $rc"; }
}

#   qemu_socket QEMU ELF WORK SECONDS SEMIHOSTING_ARGS [QEMU_FLAGS...]
# starts the emulated board in the background (at most SECONDS) with UART0 on a TCP socket on a
# free port of 127.0.0.1; the guest starts once a client connects. Sets $port and $qpid (wait for
# it); QEMU's output is WORK/qemu.out and WORK/qemu.err.
qemu_socket() {
  local qemu=$1 elf=$2 work=$3 seconds=$4 args=$5
  shift 5
  port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
  timeout "$seconds" "$qemu" -machine mps2-an500 -display none -monitor none "$@" \
    -chardev "socket,id=u0,host=127.0.0.1,port=$port,server=on,wait=on" -serial chardev:u0 \
    -semihosting-config "enable=on,target=native,$args" \
    -kernel "$elf" < /dev/null > "$work/qemu.out" 2> "$work/qemu.err" &
  qpid=$!
}

#   capture_inputs BALLVISION SRC_SEQ WORK FIRST COUNT CALIB_JSON LUT
# what the capture tests feed the board: exits 77 (skip) when the shared data is absent, else
# writes COUNT raw pairs from FIRST to WORK/seq and the calibration blob to WORK/calib.bin
# (WORK emptied first).
capture_inputs() {
  local bv=$1 src=$2 work=$3 first=$4 count=$5 calib=$6 lut=$7 f
  for f in "$src/frames.csv" "$calib" "$lut"; do
    [ -f "$f" ] || { echo "SKIP: $f not found"; exit 77; }
  done
  [ -x "$bv" ] || fail "host tool $bv not built: build the host preset first"
  rm -rf "$work" && mkdir -p "$work"
  "$bv" seq to-raw "$src" "$work/seq" --first "$first" --count "$count" > /dev/null ||
    fail "seq to-raw failed"
  "$bv" calib to-blob "$calib" "$work/calib.bin" > /dev/null || fail "calib to-blob failed"
}
