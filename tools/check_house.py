#!/usr/bin/env python3
"""House rules a review should not have to check by eye (a CTest):
- no function in core/, hal/, firmware/ or tools/ is longer than 100 lines (universal-ctags
  finds the functions and their last lines);
- hal/ includes nothing from firmware/ or tools/, core/ nothing from hal/, firmware/ or tools/.
"""
import json
import pathlib
import re
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
DIRS = ["core", "hal", "firmware", "tools"]
MAX_LINES = 100
LAYERS = {"core": ("hal/", "firmware/", "tools/"), "hal": ("firmware/", "tools/")}


def long_functions():
    ctags = shutil.which("ctags-universal") or shutil.which("ctags")
    if ctags is None:
        return ["ctags not installed (apt-get install universal-ctags)"]
    out = subprocess.run(
        [ctags, "-R", "--languages=C++,C", "--kinds-C++=f", "--kinds-C=f", "--fields=+ne",
         "--output-format=json", "-f", "-"] + DIRS,
        cwd=ROOT, capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines():
        tag = json.loads(line)
        if tag.get("_type") != "tag" or "end" not in tag:
            continue
        n = tag["end"] - tag["line"] + 1
        if n > MAX_LINES:
            name = tag.get("scope", "") + "::" + tag["name"] if "scope" in tag else tag["name"]
            found.append(f"{tag['path']}:{tag['line']}: {name} is {n} lines (max {MAX_LINES})")
    return sorted(found)


def layer_breaches():
    include = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
    found = []
    for layer, banned in LAYERS.items():
        for f in sorted((ROOT / layer).rglob("*")):
            if f.suffix not in (".h", ".hpp", ".cpp", ".c"):
                continue
            for no, text in enumerate(f.read_text(errors="replace").splitlines(), 1):
                m = include.match(text)
                if m and m.group(1).startswith(banned):
                    found.append(f"{f.relative_to(ROOT)}:{no}: {layer}/ includes {m.group(1)}")
    return found


def main():
    problems = long_functions() + layer_breaches()
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} house rule(s) broken")
        return 1
    print("house rules kept: functions <= 100 lines, layers include only downwards")
    return 0


if __name__ == "__main__":
    sys.exit(main())
