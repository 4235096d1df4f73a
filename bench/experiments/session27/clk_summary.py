#!/usr/bin/env python3
"""Median cycles of the correction's iteration phases from overlap-iteration-clocks.patch's
output (lines "CLK launch=... b=... j=... k=... tail=... count=... gather=... sums=... apply=...
check=... end=..."), block 0 only, by kind: iteration 0, a team iteration, a tail iteration.
    clk_summary.py c7/clk-1024.txt [more files...]"""
import collections
import re
import sys

PHASES = ("count", "gather", "sums", "apply", "check", "end")

for path in sys.argv[1:]:
    by_kind = collections.defaultdict(list)
    for line in open(path):
        if not line.startswith("CLK") or " last " in line:
            continue
        d = dict(re.findall(r"(\w+)=(-?\d+)", line))
        if d["b"] != "0":
            continue
        kind = "iteration 0" if d["k"] == "0" else "tail" if d["tail"] == "1" else "team"
        by_kind[kind].append([int(d[p]) for p in PHASES])
    for kind, rows in by_kind.items():
        med = [sorted(col)[len(col) // 2] for col in zip(*rows)]
        print(f"{path}: {kind} ({len(rows)} iterations): " +
              ", ".join(f"{p} {v}" for p, v in zip(PHASES, med)) + f"; total {sum(med[1:])}")
