#!/usr/bin/python3
"""Summarize a GPU timeline written by libflipflow_gpu_trace.so (README.md): the typical step.

A step starts at each GPU activity whose name contains --step-marker (default "abp": the ABP
integrate kernel is ff::after_previous_kernel<ff::overdamped::OverdampedStep<double, 2, false,
ff::abp::SelfPropulsion<double, 2>, false>>) and ends where the next one
starts; the last marker (no next one) starts an unfinished step, which is left out. The first
--skip steps are left out, then --count steps are used (default: all the rest). A rolled-back step
runs the marker kernel again, so it shows up as two short steps.

Steps are grouped by their sequence of GPU activities (kind and name) and of host waits
(cudaStreamSynchronize, cudaMemcpy, ...); the most common group (or --group K) is printed in
order: per activity its median duration, how far it extends the step (its end minus the later of
its start and the end of everything before it: a kernel launched programmatically starts while the
one before it runs, so durations overlap and these do not), the median GPU idle gap before it (no
GPU activity on any stream between the end of everything before it and its start), and the median
time from the
start of the host call that issued it to its start on the GPU (small values: the GPU waited for
the host). Then totals, the host waits, the other groups in one line each, and a table per
kernel/copy name over all used steps (robust when the sequence varies, e.g. Lawson's rounds).

`pipeline bench` runs warm-up steps, then three passes of --steps steps: back-to-back (one wait at
the end), each step waited for, each stage waited for. Their host waits differ, so they land in
different groups; --skip WARMUP --count STEPS keeps the first (back-to-back) pass only.
"""
import argparse
import bisect
import collections
import csv
import re
import signal
import statistics
import sys

GPU_KINDS = ("kernel", "memcpy", "memset")
# Host calls that block the calling thread until the GPU (or a stream) catches up.
HOST_WAITS = {"cudaStreamSynchronize", "cudaEventSynchronize", "cudaDeviceSynchronize",
              "cudaMemcpy", "cudaMemset", "cudaMalloc", "cudaFree"}


class Rec:
    __slots__ = ("kind", "name", "start", "end", "stream", "bytes", "corr")

    def __init__(self, row):
        self.kind = row["kind"]
        self.name = row["name"]
        self.start = int(row["start_ns"])
        self.end = int(row["end_ns"])
        self.stream = row.get("stream") or ""
        b = row.get("bytes") or ""
        self.bytes = int(b) if b else None
        c = row.get("correlation") or ""
        self.corr = int(c) if c else 0


def load(path):
    try:
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            need = {"kind", "name", "start_ns", "end_ns"}
            if not reader.fieldnames or not need <= set(reader.fieldnames):
                sys.exit(f"summarize: {path}: not a gpu_trace CSV (header needs {sorted(need)})")
            return [Rec(r) for r in reader]
    except OSError as e:
        sys.exit(f"summarize: {e}")


def short(name, full):
    if full:
        return name
    s = name.replace("(anonymous namespace)::", "")
    s = re.sub(r"\bff::", "", s)
    if len(s) > 60 and "<" in s:  # e.g. cub's kernels: keep the function, drop the arguments
        base = s[: s.index("<")]
        s = base.rsplit("::", 1)[-1] + "<...>"
    return s


def med(xs):
    xs = [x for x in xs if x is not None]
    return statistics.median(xs) if xs else None


def us(ns, width=9):
    return f"{'-':>{width}}" if ns is None else f"{ns / 1e3:>{width}.1f}"


def fmt_bytes(b):
    if b is None:
        return ""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if b >= scale:
            return f"{b / scale:.1f} {unit}"
    return f"{int(b)} B"


class Step:
    pass


def build_steps(gpu, api, marker):
    marks = [i for i, a in enumerate(gpu) if marker in a.name]
    if not marks:
        names = collections.Counter(a.name for a in gpu if a.kind == "kernel")
        top = "\n  ".join(f"{n}x {k}" for k, n in names.most_common(15))
        sys.exit(f"summarize: no GPU activity name contains '{marker}' (--step-marker); "
                 f"most frequent kernels:\n  {top}")
    max_end_before = [0] * (len(gpu) + 1)  # max end over gpu[0..i-1]
    m = 0
    for i, a in enumerate(gpu):
        max_end_before[i] = m
        m = max(m, a.end)
    max_end_before[len(gpu)] = m
    api_by_corr = {a.corr: a for a in api if a.corr}
    api_starts = [a.start for a in api]

    steps = []
    bounds = marks + [len(gpu)]
    for k in range(len(marks)):
        lo, hi = bounds[k], bounds[k + 1]
        s = Step()
        s.index = k
        s.t0 = gpu[lo].start
        s.t1 = gpu[hi].start if hi < len(gpu) else max_end_before[hi]
        s.acts = gpu[lo:hi]
        s.gaps = [None] + [max(0, gpu[j].start - max_end_before[j]) for j in range(lo + 1, hi)]
        # How far each activity takes the step's GPU work past what ran before it: its end minus
        # the later of its start and the end of everything before it in the step. A kernel
        # launched programmatically (core/backend/cuda/pdl.cuh) starts while the one before it
        # runs, so its duration overlaps that one's; these add up (with the gaps) to the step.
        s.extends = [max(0, gpu[j].end - max(gpu[j].start, max_end_before[j] if j > lo else s.t0))
                     for j in range(lo, hi)]
        s.trailing = max(0, s.t1 - max_end_before[hi]) if hi < len(gpu) else 0
        busy, cur_s, cur_e = 0, None, None  # union of the activities, clipped to [t0, t1)
        for a in s.acts:
            st, en = max(a.start, s.t0), min(a.end, s.t1)
            if en <= st:
                continue
            if cur_e is None or st > cur_e:
                busy += (cur_e - cur_s) if cur_e is not None else 0
                cur_s, cur_e = st, en
            else:
                cur_e = max(cur_e, en)
        busy += (cur_e - cur_s) if cur_e is not None else 0
        s.busy = busy
        s.length = s.t1 - s.t0
        s.issue = []
        for a in s.acts:
            call = api_by_corr.get(a.corr)
            s.issue.append(a.start - call.start if call else None)
        # Host calls of this step: between the host calls that issued this marker and the next
        # (falls back to the GPU window when the launches were not recorded).
        h0 = api_by_corr[gpu[lo].corr].start if gpu[lo].corr in api_by_corr else s.t0
        if hi < len(gpu) and gpu[hi].corr in api_by_corr:
            h1 = api_by_corr[gpu[hi].corr].start
        elif hi < len(gpu):
            h1 = s.t1
        else:
            h1 = float("inf")
        i0, i1 = bisect.bisect_left(api_starts, h0), bisect.bisect_left(api_starts, h1)
        s.waits = [a for a in api[i0:i1] if a.name in HOST_WAITS]
        s.n_api = i1 - i0
        s.last = hi == len(gpu)
        s.key = tuple((a.kind, a.name) for a in s.acts) + ("|",) + tuple(w.name for w in s.waits)
        steps.append(s)
    return steps


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    p.add_argument("csv", help="trace written by libflipflow_gpu_trace.so (FLIPFLOW_GPU_TRACE)")
    p.add_argument("--step-marker", default="abp",
                   help="a step starts at each GPU activity whose name contains this (default: abp)")
    p.add_argument("--skip", type=int, default=5, help="leave out the first N steps (default: 5)")
    p.add_argument("--count", type=int, default=0,
                   help="use N steps after the skipped ones (default: all the rest)")
    p.add_argument("--group", type=int, default=1,
                   help="print the K-th most common step sequence in full (default: 1)")
    p.add_argument("--per-step", action="store_true", help="also print one line per step")
    p.add_argument("--full-names", action="store_true", help="do not shorten kernel names")
    args = p.parse_args()
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # quiet when piped into head

    recs = load(args.csv)
    gpu = sorted((r for r in recs if r.kind in GPU_KINDS), key=lambda r: (r.start, r.end))
    api = sorted((r for r in recs if r.kind == "api"), key=lambda r: r.start)
    if not gpu:
        sys.exit(f"summarize: {args.csv} holds no GPU activity (kernel/memcpy/memset) records")
    all_steps = build_steps(gpu, api, args.step_marker)
    # The last step has no next marker: its end is the end of the GPU work, teardown copies
    # included; leave it out unless it is all there is.
    complete = [s for s in all_steps if not s.last] or all_steps
    steps = complete[args.skip:]
    if args.count > 0:
        steps = steps[: args.count]
    if not steps:
        sys.exit(f"summarize: {len(complete)} complete steps found, none left after --skip {args.skip}")
    print(f"{args.csv}: {len(gpu)} GPU activities, {len(api)} host API calls; "
          f"{len(complete)} complete steps (marker '{args.step_marker}'), "
          f"using steps {steps[0].index}..{steps[-1].index} ({len(steps)})")
    if not api:
        print("  (no host API records: host waits and issue->start are not available)")

    groups = collections.defaultdict(list)
    for s in steps:
        groups[s.key].append(s)
    ranked = sorted(groups.values(), key=lambda g: (-len(g), g[0].index))
    rank_of = {id(s): r + 1 for r, g in enumerate(ranked) for s in g}
    if not 1 <= args.group <= len(ranked):
        sys.exit(f"summarize: --group {args.group}: there are {len(ranked)} groups")
    g = ranked[args.group - 1]
    ref = g[0]
    nm = lambda a: short(a.name, args.full_names)

    print(f"\nTypical step: group {args.group} of {len(ranked)}, {len(g)} of {len(steps)} steps "
          f"(steps {', '.join(str(s.index) for s in g[:8])}{', ...' if len(g) > 8 else ''}); "
          f"medians in us")
    print(f"{'#':>3}  {'kind':<6}  {'name':<52} {'bytes':>10} {'duration':>9} {'extends':>9} "
          f"{'gap before':>10} {'issue->start':>12}")
    for j, a in enumerate(ref.acts):
        dur = med([s.acts[j].end - s.acts[j].start for s in g])
        ext = med([s.extends[j] for s in g])
        gap = med([s.gaps[j] for s in g])
        issue = med([s.issue[j] for s in g])
        b = med([s.acts[j].bytes for s in g]) if a.kind != "kernel" else None
        print(f"{j:>3}  {a.kind:<6}  {nm(a):<52} {fmt_bytes(b):>10} {us(dur)} {us(ext)} {us(gap, 10)} "
              f"{us(issue, 12)}")
    print(f"{'':>3}  {'idle':<6}  {'(until the next step marker)':<52} {'':>10} {'':>9} {'':>9} "
          f"{us(med([s.trailing for s in g]), 10)}")
    length = med([s.length for s in g])
    busy = med([s.busy for s in g])
    gaps = med([s.length - s.busy for s in g])
    print(f"\n  step length {us(length, 0).strip()} us = GPU busy {us(busy, 0).strip()} us "
          f"+ GPU idle {us(gaps, 0).strip()} us (medians; idle {100 * gaps / length:.0f}%)"
          if length else "\n  step length 0")
    print(f"  {len(ref.acts)} GPU activities per step: "
          + ", ".join(f"{n} {k}" for k, n in
                      collections.Counter(a.kind for a in ref.acts).most_common())
          + (f"; {med([s.n_api for s in g]):.0f} recorded host API calls" if api else ""))

    if api:
        if ref.waits:
            print(f"\n  host waits in the step (blocking calls; medians in us): "
                  f"total {us(med([sum(w.end - w.start for w in s.waits) for s in g]), 0).strip()}")
            for j, w in enumerate(ref.waits):
                d = med([s.waits[j].end - s.waits[j].start for s in g])
                at = med([s.waits[j].start - s.t0 for s in g])
                print(f"    {w.name:<24} {us(d)} us, starting {us(at, 0).strip()} us after the "
                      f"step's marker started on the GPU")
        else:
            print("\n  host waits in the step: none")

    if len(ranked) > 1:
        print(f"\nOther groups ({len(steps) - len(g)} steps):")
        ref_names = collections.Counter(ref.key)
        for r, og in enumerate(ranked, 1):
            if og is g:
                continue
            o = og[0]
            diff = collections.Counter(o.key)
            diff.subtract(ref_names)
            parts = [f"{'+' if n > 0 else ''}{n} {short(k[1], args.full_names) if isinstance(k, tuple) else k}"
                     for k, n in diff.items() if n and k != "|"]
            parts = parts[:4] + (["..."] if len(parts) > 4 else [])
            print(f"  group {r}: {len(og)} steps (e.g. {og[0].index}), {len(o.acts)} activities, "
                  f"{len(o.waits)} host waits; step {us(med([s.length for s in og]), 0).strip()} us, "
                  f"busy {us(med([s.busy for s in og]), 0).strip()} us; vs group {args.group}: "
                  f"{', '.join(parts) if parts else 'same names, other order'}")

    # Per name over every used step: robust when the sequence varies from step to step.
    per = collections.defaultdict(lambda: collections.defaultdict(lambda: [0, 0, 0]))
    for s in steps:
        for a, gap in zip(s.acts, s.gaps):
            c = per[(a.kind, a.name)][s.index]
            c[0] += 1
            c[1] += a.end - a.start
            c[2] += gap or 0
    n = len(steps)
    rows = []
    for (kind, name), by_step in per.items():
        calls = [by_step[s.index][0] if s.index in by_step else 0 for s in steps]
        tot = [by_step[s.index][1] if s.index in by_step else 0 for s in steps]
        gap = [by_step[s.index][2] if s.index in by_step else 0 for s in steps]
        rows.append((sum(tot) / n, kind, name, statistics.mean(calls), sum(gap) / n))
    rows.sort(reverse=True)
    mean_len = statistics.mean(s.length for s in steps)
    print(f"\nPer name, all {n} used steps (means per step, us; step mean {us(mean_len, 0).strip()} us):")
    print(f"  {'kind':<6}  {'name':<52} {'calls':>6} {'time':>9} {'% step':>6} {'gaps before':>11}")
    for tot, kind, name, calls, gap in rows:
        print(f"  {kind:<6}  {short(name, args.full_names):<52} {calls:>6.1f} {us(tot)} "
              f"{100 * tot / mean_len if mean_len else 0:>6.1f} {us(gap, 11)}")
    print(f"  {'idle':<6}  {'(until the next step marker)':<52} {'':>6} "
          f"{us(statistics.mean(s.trailing for s in steps))}")

    if args.per_step:
        print(f"\nPer step (us):\n  {'step':>5} {'group':>5} {'length':>9} {'busy':>9} {'idle':>9} "
              f"{'acts':>5} {'waits':>9}")
        for s in steps:
            print(f"  {s.index:>5} {rank_of[id(s)]:>5} {us(s.length)} {us(s.busy)} "
                  f"{us(s.length - s.busy)} {len(s.acts):>5} "
                  f"{us(sum(w.end - w.start for w in s.waits))}")


if __name__ == "__main__":
    main()
