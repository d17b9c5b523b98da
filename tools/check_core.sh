#!/usr/bin/env bash
# Static checks on core/ (a CTest): it must not include hal/ or OpenCV, nor use the heap,
# exceptions or RTTI; and cppcheck must find nothing with the checks listed below.
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
fail=0
if grep -rnE '#include\s*[<"](hal/|opencv)' core; then
  echo "core/ includes hal/ or OpenCV"; fail=1
fi
# Code only: comments stripped before matching.
code_lines() {
  find core -name '*.h' -o -name '*.cpp' | sort | while read -r f; do
    sed -e 's://.*$::' "$f" | awk -v f="$f" '{ print f ":" NR ": " $0 }'
  done
}
if code_lines | grep -E '\b(malloc|calloc|realloc|free)\s*\(|\bnew\s+[A-Za-z_:(]|\bdelete\b|std::(vector|string|map|unordered_map|list|deque|function|shared_ptr|unique_ptr|make_unique|make_shared)\b|<iostream>|\bthrow\b|\btry\s*\{|dynamic_cast|typeid' \
    | grep -vE '=\s*delete'; then
  echo "core/ uses the heap, exceptions or RTTI"; fail=1
fi
# cppcheck checks: warning (undefined behaviour, bad logic), performance, portability.
if command -v cppcheck >/dev/null; then
  cppcheck --quiet --std=c++20 --language=c++ --enable=warning,performance,portability \
    --inline-suppr --error-exitcode=1 -I . --suppress=missingIncludeSystem core/ || fail=1
else
  echo "cppcheck not installed"; fail=1
fi
[ "$fail" -eq 0 ] && echo "core/ checks passed"
exit "$fail"
