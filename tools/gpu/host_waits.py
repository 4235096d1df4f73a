#!/usr/bin/env python3
# Reads tools/gpu/host_waits.c's records of one `pipeline bench` size (warm-up W, S steps a pass) and prints,
# over the back-to-back pass (the steps between W + 5 and W + S - 5), the medians per step of: the
# step's period on the host (from one cudaLaunchKernelExC of the step's first kernel to the next: the
# integrator's in bench-abp), the time the
# host spent waiting (event, stream and device synchronizations) and what is left (the host's own
# work: the stages' host code, the launches and the records), and the launch calls' time; then the
# typical step's calls in order (the commonest sequence of kinds), each with its median start
# (from the step's first launch) and duration: the gaps between them are the stages' host code.
#   host_waits.py FILE W S
import statistics
import sys

path, warmup, steps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
recs = []
kernel_name = {}
for line in open(path):
    k, t0, t1, f = line.split()[:4]
    recs.append((k, int(t0), int(t1), f))
    if k in 'LK' and len(line.split()) > 4:
        kernel_name[f] = line.split()[4]
launches = [r for r in recs if r[0] == 'L']
counts = {}
for r in launches:
    counts[r[3]] = counts.get(r[3], 0) + 1
top = max(counts.values())
first = next(r[3] for r in launches if counts[r[3]] == top)  # the step's first kernel
starts = [r[1] for r in launches if r[3] == first]
kernels = sum(1 for c in counts.values() if c == top)
period, waited, launch_time = [], [], []
for i in range(warmup + 5, min(warmup + steps - 5, len(starts) - 1)):
    a, b = starts[i], starts[i + 1]
    period.append((b - a) / 1e3)
    waited.append(sum(min(r[2], b) - max(r[1], a) for r in recs if r[0] in 'ESD' and r[2] > a and r[1] < b) / 1e3)
    launch_time.append(sum(r[2] - r[1] for r in recs if r[0] in 'LK' and a <= r[1] < b) / 1e3)
own = [p - w for p, w in zip(period, waited)]
m = statistics.median
print(f"{path}: {len(period)} steps, {kernels} kernels of {top} launches each; medians per step, us: "
      f"period {m(period):.1f}, waiting {m(waited):.1f}, host's own {m(own):.1f} (launch calls {m(launch_time):.1f})")

names = {'L': 'cudaLaunchKernelExC', 'K': '__cudaLaunchKernel', 'E': 'cudaEventSynchronize', 'S': 'cudaStreamSynchronize',
         'D': 'cudaDeviceSynchronize', 'R': 'cudaEventRecord', 'W': 'cudaStreamWaitEvent',
         'M': 'cudaMemcpyAsync', 'Z': 'cudaMemsetAsync', 'G': 'cudaGraphLaunch', 'Q': 'cudaEventQuery'}
seqs = {}
for i in range(warmup + 5, min(warmup + steps - 5, len(starts) - 1)):
    a, b = starts[i], starts[i + 1]
    calls = [r for r in recs if a <= r[1] < b]
    key = ''.join(r[0] for r in calls)
    seqs.setdefault(key, []).append([(r[1] - a, r[2] - r[1], r[3]) for r in calls])
key, runs = max(seqs.items(), key=lambda kv: len(kv[1]))
print(f"  typical step: {len(runs)} of {sum(len(v) for v in seqs.values())} steps, {len(key)} calls")
kernel_names = {}
for j, k in enumerate(key):
    at = m([run[j][0] for run in runs]) / 1e3
    d = m([run[j][1] for run in runs]) / 1e3
    what = kernel_name.get(runs[0][j][2], '') if k in 'LK' else ''
    print(f"    {at:7.1f} us  {names.get(k, k):22s} {d:6.1f} us  {what[:90]}")
