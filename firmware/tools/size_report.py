#!/usr/bin/env python3
"""Firmware size report against the DESIGN.md §5 budgets.

Flash = .text + .ARM.exidx + .data (load image). Static RAM = .data + .bss, excluding the
frame-buffer sections (PSRAM / SDRAM) named by --frame-sections. Heap must be 0: no allocator
symbol may be linked. Worst-case stack comes from GCC's -fcallgraph-info=su graphs (.ci files):
the deepest path from the entry points, where an indirect call (the HAL's virtual Do* methods)
is charged with the deepest virtual function in the image.
"""
import argparse
import glob
import os
import re
import subprocess
import sys


def sections(size_tool, elf):
    out = subprocess.run([size_tool, "-A", elf], check=True, capture_output=True, text=True).stdout
    result = {}
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0].startswith(".") and parts[1].isdigit():
            result[parts[0]] = int(parts[1])
    return result


NODE_RE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
EDGE_RE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
STACK_RE = re.compile(r"\\n(\d+) bytes \((static|dynamic|dynamic,bounded)\)")


def load_callgraph(ci_dir):
    frames, labels, edges = {}, {}, {}
    for path in glob.glob(os.path.join(ci_dir, "**", "*.ci"), recursive=True):
        with open(path, errors="replace") as f:
            text = f.read()
        for title, label in NODE_RE.findall(text):
            m = STACK_RE.search(label)
            if m:
                frames[title] = max(frames.get(title, 0), int(m.group(1)))
                labels[title] = label
        for src, dst in EDGE_RE.findall(text):
            edges.setdefault(src, set()).add(dst)
    return frames, labels, edges


def symbol_of(title):
    return title.rsplit(":", 1)[-1]


def worst_stack(frames, labels, edges, linked, roots):
    # Only functions that survived --gc-sections matter.
    by_symbol = {}
    for title in frames:
        by_symbol.setdefault(symbol_of(title), []).append(title)
    virtuals = [t for t, l in labels.items() if l.startswith("virtual ") and symbol_of(t) in linked]
    memo, unknown, recursion = {}, set(), set()

    # An indirect call (virtual HAL / sink methods, function pointers) is charged with the
    # deepest virtual function reachable through direct calls only: one level of dispatch,
    # which is what the firmware does (no virtual call inside a virtual callee nests further).
    def depth(title, stack, follow_indirect=True):
        key = (title, follow_indirect)
        if key in memo:
            return memo[key]
        if key in stack:
            recursion.add(symbol_of(title))
            return 0, [title]
        stack.add(key)
        best, best_path = 0, []
        targets = set(edges.get(title, ()))
        indirect = "__indirect_call" in targets
        targets.discard("__indirect_call")
        calls = [(t, follow_indirect) for t in targets]
        if indirect and follow_indirect:
            calls += [(v, False) for v in virtuals if v != title]
        for dst, follow in calls:
            sym = symbol_of(dst)
            cands = [dst] if dst in frames else by_symbol.get(sym, [])
            if not cands and "C1E" in sym:  # complete-object ctor: an alias of the base ctor
                cands = by_symbol.get(sym.replace("C1E", "C2E", 1), [])
            if not cands:
                unknown.add(sym)
                continue
            for c in cands:
                d, p = depth(c, stack, follow)
                if d > best:
                    best, best_path = d, p
        stack.discard(key)
        memo[key] = (frames.get(title, 0) + best, [title] + best_path)
        return memo[key]

    results = []
    for root in roots:
        for title in by_symbol.get(root, []):
            results.append(depth(title, set()))
    if not results:
        return 0, [], unknown, recursion
    d, path = max(results, key=lambda r: r[0])
    return d, path, unknown, recursion


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elf", required=True)
    ap.add_argument("--size", required=True)
    ap.add_argument("--nm", required=True)
    ap.add_argument("--frame-sections", default="")
    ap.add_argument("--ci-dir", required=True)
    ap.add_argument("--ram-budget", type=int, default=128 * 1024)
    ap.add_argument("--flash-budget", type=int, default=256 * 1024)
    ap.add_argument("--stack-budget", type=int, default=8 * 1024)
    ap.add_argument("--strict", action="store_true", help="exit 1 when a budget is exceeded")
    args = ap.parse_args()

    print(subprocess.run([args.size, args.elf], check=True, capture_output=True,
                         text=True).stdout.rstrip())
    sec = sections(args.size, args.elf)
    frame_secs = [s for s in args.frame_sections.replace(";", " ").split() if s]
    flash = sec.get(".text", 0) + sec.get(".ARM.exidx", 0) + sec.get(".rodata", 0) + \
        sec.get(".data", 0) + sec.get(".isr_vector", 0)
    ram = sec.get(".data", 0) + sec.get(".bss", 0) + sec.get(".noinit", 0)
    frames = sum(sec.get(s, 0) for s in frame_secs)
    nm = subprocess.run([args.nm, "-C", args.elf], check=True, capture_output=True,
                        text=True).stdout
    linked = set()
    nm_raw = subprocess.run([args.nm, args.elf], check=True, capture_output=True,
                            text=True).stdout
    for line in nm_raw.splitlines():
        parts = line.split()
        if len(parts) >= 3:
            linked.add(parts[2])
    allocators = sorted(s for s in ("malloc", "_malloc_r", "_sbrk", "free", "_free_r", "calloc",
                                    "realloc") if s in linked)
    del nm
    cg_frames, cg_labels, cg_edges = load_callgraph(args.ci_dir)
    stack, path, unknown, recursion = worst_stack(cg_frames, cg_labels, cg_edges, linked,
                                                  ["Reset_Handler"])
    # Interrupts nest on the same (main) stack: add every handler's own worst case plus its
    # exception frame with FP context (26 words), as if all preempted at the deepest point.
    isr_roots = sorted(s for s in linked if (s.endswith("_IRQHandler") and
                                             not s.startswith("_GLOBAL_")) or
                       s in ("FaultReport", "Default_Handler"))
    isr_total = 0
    isr_parts = []
    for root in isr_roots:
        d, _, u, r = worst_stack(cg_frames, cg_labels, cg_edges, linked, [root])
        unknown |= u
        recursion |= r
        isr_total += d + 104
        isr_parts.append(f"{root} {d}+104")
    stack += isr_total

    def row(name, value, budget):
        verdict = "ok" if value <= budget else "OVER BUDGET"
        print(f"  {name:<38} {value:>9} B  budget {budget:>7} B  {verdict}")
        return value <= budget

    print("budgets (DESIGN.md §5):")
    ok = row("flash (text+exidx+data)", flash, args.flash_budget)
    ok &= row("static RAM excl. frame buffers", ram, args.ram_budget)
    big = []
    for line in subprocess.run([args.nm, "-S", "--size-sort", "-C", args.elf], check=True,
                               capture_output=True, text=True).stdout.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[2] in "bBdD" and not parts[0].startswith(("6", "c", "C")):
            big.append((int(parts[1], 16), parts[3]))
    for size, name in sorted(big, reverse=True)[:4]:
        print(f"    {size:>9} B  {name}")
    print(f"  {'frame buffers / external RAM':<38} {frames:>9} B  ({', '.join(frame_secs)})")
    ok &= row("heap", 0 if not allocators else 1, 0)
    if allocators:
        print("    allocator symbols linked: " + ", ".join(allocators))
    ok &= row("worst-case stack (call graph)", stack, args.stack_budget)
    if path:
        names = [symbol_of(t) for t in path]
        try:
            names = subprocess.run([args.nm.replace("-nm", "-c++filt")] + names, check=True,
                                   capture_output=True, text=True).stdout.split("\n")
        except OSError:
            pass
        print("    deepest path: " + " -> ".join(
            f"{re.sub(r'[(].*', '', n)}({cg_frames.get(t, 0)})" for n, t in zip(names, path)))
    if isr_parts:
        print("    plus interrupts: " + ", ".join(isr_parts))
    libs = sorted(u for u in unknown if not u.startswith("__builtin"))
    if libs:
        print("    not in the call graph (library code, counted as 0): " + ", ".join(libs[:12]) +
              (" ..." if len(libs) > 12 else ""))
    if recursion:
        print("    RECURSION (depth not bounded): " + ", ".join(sorted(recursion)))
    if not ok:
        print("OVER BUDGET (see above)")
    return 0 if ok or not args.strict else 1


if __name__ == "__main__":
    sys.exit(main())
