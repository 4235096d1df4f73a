#!/usr/bin/env python3
"""Symbolises host_profile.c's samples and prints where the host's CPU time went.

  host_profile.py PROF.txt [--root DIR] [--top K] [--thread main|all]

PROF.txt: the preloaded library's output (sample lines "S TID PC...", then the process's maps
"M ..."). Each PC is mapped to its file and offset through the maps; a file is looked up as
mapped, or, with --root (the bundle the run used, unpacked here), only under it by the part of
its path from bin/, lib/ or plugins/ on (another machine's system libraries stay FILE+offset);
addr2line -f -C names the function. Prints, per function, the
samples it was running in (own) and the samples it was on the stack of (inclusive, once a
sample), with their share of the samples taken; --thread main (the default) keeps the thread
with the most samples only (the step loop's, in a chain).
"""
import argparse
import bisect
import collections
import os
import subprocess
import sys


def parse(path):
    samples, maps = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("S "):
                parts = line.split()
                samples.append((int(parts[1]), [int(p, 16) for p in parts[2:] if p != "(nil)"]))
            elif line.startswith("M "):
                fields = line[2:].split(None, 5)
                if len(fields) < 6 or "x" not in fields[1]:
                    continue
                lo, hi = (int(x, 16) for x in fields[0].split("-"))
                maps.append((lo, hi, int(fields[2], 16), fields[5].strip()))
    # Several snapshots (before each dlclose, at exit): each mapping once, the first taken kept
    # where a range was later reused.
    seen, kept = set(), []
    for m in maps:
        if m[0] not in seen:
            seen.add(m[0])
            kept.append(m)
    maps = sorted(kept)
    return samples, maps


def locate(maps, starts, pc):
    i = bisect.bisect_right(starts, pc) - 1
    if i >= 0 and maps[i][0] <= pc < maps[i][1]:
        lo, _, off, path = maps[i]
        return path, pc - lo + off
    return None, pc


def local_file(path, root):
    # With --root the run was on another machine: only the bundle's own files are the same
    # binaries here (a system library of the same name is another build, whose names would lie).
    if not root:
        return path if os.path.exists(path) else None
    parts = path.split("/")
    for k, p in enumerate(parts):
        if p in ("bin", "lib", "plugins"):
            cand = os.path.join(root, *parts[k:])
            if os.path.exists(cand):
                return cand
    return None


def vaddr_of(path, offset, cache={}):
    """The file offset as the ELF's virtual address (the executable LOAD segment's delta)."""
    if path not in cache:
        segs = []
        try:
            out = subprocess.run(["readelf", "-lW", path], capture_output=True, text=True).stdout
            for line in out.splitlines():
                w = line.split()
                if w and w[0] == "LOAD":
                    segs.append((int(w[1], 16), int(w[2], 16), int(w[4], 16)))  # offset, vaddr, filesz
        except OSError:
            pass
        cache[path] = segs
    for off, va, size in cache[path]:
        if off <= offset < off + size:
            return offset - off + va
    return offset


def symbolise(keys, root):
    """{(path, offset): name}, by one addr2line call per file."""
    names = {}
    by_file = collections.defaultdict(set)
    for path, off in keys:
        by_file[path].add(off)
    for path, offs in by_file.items():
        offs = sorted(offs)
        base = os.path.basename(path) if path else "?"
        f = local_file(path, root) if path else None
        if not f:
            for o in offs:
                names[(path, o)] = f"{base}+{o:#x}"
            continue
        addrs = [vaddr_of(f, o) for o in offs]
        try:
            out = subprocess.run(["addr2line", "-f", "-C", "-e", f] + [f"{a:#x}" for a in addrs],
                                 capture_output=True, text=True).stdout.splitlines()
        except OSError:
            out = []
        for k, o in enumerate(offs):
            fn = out[2 * k] if 2 * k < len(out) else "??"
            names[(path, o)] = (fn if fn != "??" else f"{base}+{o:#x}") + f" [{base}]"
    return names


def short(name, width=150):
    return name if len(name) <= width else name[: width - 3] + "..."


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("prof")
    ap.add_argument("--root", help="the bundle the run used, unpacked here")
    ap.add_argument("--top", type=int, default=40)
    ap.add_argument("--thread", default="main", choices=["main", "all"])
    a = ap.parse_args()
    samples, maps = parse(a.prof)
    if not samples:
        sys.exit("host_profile: no samples in " + a.prof)
    per_tid = collections.Counter(t for t, _ in samples)
    if a.thread == "main":
        tid = per_tid.most_common(1)[0][0]
        samples = [s for s in samples if s[0] == tid]
    starts = [m[0] for m in maps]
    located = [[locate(maps, starts, pc - (1 if k else 0)) for k, pc in enumerate(st)] for _, st in samples]
    names = symbolise({x for st in located for x in st}, a.root)
    own, incl = collections.Counter(), collections.Counter()
    for st in located:
        if not st:
            continue
        own[names[st[0]]] += 1
        for n in {names[x] for x in st}:
            incl[n] += 1
    total = len(located)
    print(f"{total} samples ({'thread ' + str(samples[0][0]) if a.thread == 'main' else 'all threads'}; "
          f"threads: {dict(per_tid.most_common(6))})")
    print(f"\nown (the function running):")
    for n, c in own.most_common(a.top):
        print(f"  {100 * c / total:5.1f} %  {short(n)}")
    print(f"\ninclusive (on the stack):")
    for n, c in incl.most_common(a.top):
        print(f"  {100 * c / total:5.1f} %  {short(n)}")


if __name__ == "__main__":
    main()
