#!/usr/bin/env bash
# One entry point for people and CI:
#   tools/dev.sh deps    install what the project needs (Debian 12, apt-get, idempotent)
#   tools/dev.sh demo    deps + host build + `ballvision demo` (the main job, no external data)
#   tools/dev.sh test    deps + build every preset + run every suite (host, sanitizers, QEMU, fuzz)
#   tools/dev.sh build   build every preset without testing
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake ninja-build git pkg-config
  libeigen3-dev libgtest-dev libgmock-dev googletest libbenchmark-dev
  libopencv-dev libpng-dev libjpeg-dev nlohmann-json3-dev
  gcc-arm-none-eabi binutils-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib
  qemu-system-arm
  python3 python3-numpy python3-matplotlib python3-serial python3-sklearn
  chromium chromium-driver python3-selenium fonts-dejavu-core
  clang libclang-rt-14-dev cppcheck clang-tidy clang-format universal-ctags
)

deps() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]})); then
    echo "== installing: ${missing[*]}"
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
      "${missing[@]}" >/dev/null
  fi
}

build_preset() {
  cmake --preset "$1" >/dev/null
  cmake --build --preset "$1"
}

case "${1:-}" in
  deps) deps ;;
  demo)
    deps
    build_preset host
    shift
    ./build/host/tools/ballvision demo "$@"
    ;;
  build)
    deps
    for p in host host-sanitize fw-qemu fw-stm32h7 fuzz; do build_preset "$p"; done
    ;;
  test)
    deps
    for p in host host-sanitize fw-qemu fw-stm32h7 fuzz; do
      echo "== build $p"
      build_preset "$p"
    done
    # Every suite runs even after one failed (the summary says which); each one's wall time and
    # its five slowest tests are printed at the end.
    rc=0
    summary=()
    log=$(mktemp)
    for p in host host-sanitize fw-qemu fw-stm32h7 fuzz; do
      echo "== test $p"
      start=$SECONDS
      status=passed
      ctest --preset "$p" | tee "$log" || { status=FAILED; rc=1; }
      # No `head`: under pipefail, sort killed by SIGPIPE would end the script.
      slowest=$(sed -nE 's/^ *[0-9]+\/[0-9]+ +Test +#[0-9]+: ([^ ]+) .* ([0-9.]+) sec$/\2 \1/p' "$log" |
        sort -rn | awk 'NR <= 5 { printf "%s%s %.1f s", (NR > 1 ? ", " : ""), $2, $1 }')
      summary+=("$(printf '%-14s %-6s %5d s wall; slowest: %s' "$p" "$status" \
        $((SECONDS - start)) "${slowest:-none}")")
    done
    rm -f "$log"
    echo "== suites"
    printf '%s\n' "${summary[@]}"
    exit $rc
    ;;
  *)
    sed -n '2,6p' "$0"
    exit 2
    ;;
esac
