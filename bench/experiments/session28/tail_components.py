#!/usr/bin/python3
"""How the correction's tail iterations split into independent groups (session 28, issue 20).

Reads the trace of `overlap-trace-worklists.patch` (FF_OC_TRACE: each work-list iteration's
candidates, whether each moved, and its Delaunay neighbours; CPU, one thread) and, for each step's
tail (the iterations after one that moved at most T particles, T = 256 for a run alone's cluster,
512 for the grid), the groups of particles that could iterate on their own: connected components
of the tail's candidates, joined where a candidate neighbours a particle that moves in the tail
(a gather reads its neighbours' positions; a particle that never moves in the tail reads the
same whenever). A group that contains candidates of several groups of the tail's first iteration
merged on the way.

It also counts what a tail that kept its particles in shared memory would have to load: the
region at the tail's start is its first iteration's candidates and their neighbours; each later
iteration loads the neighbour lists of candidates not yet listed and the positions of neighbours
not yet in the region. Steps before SKIP (default 20, as `pipeline bench`'s warm-up) are left out.

  tail_components.py TRACE T [SKIP]
"""
import sys
from collections import defaultdict


def steps(path):
    step, last_k = [], None
    cur = None
    for line in open(path):
        f = line.split()
        if f[0] == 'W':
            k = int(f[1])
            if last_k is not None and k <= last_k:
                yield step
                step = []
            last_k = k
            cur = (k, [])
            step.append(cur)
        else:
            cur[1].append((int(f[1]), f[2] == '1', [int(x) for x in f[3:]]))
    if step:
        yield step


def find(p, x):
    while p[x] != x:
        p[x] = p[p[x]]
        x = p[x]
    return x


def main():
    path, T = sys.argv[1], int(sys.argv[2])
    skip = int(sys.argv[3]) if len(sys.argv) > 3 else 20
    rows = []
    loads = []  # per later tail iteration: (candidates, lists to load, positions to load)
    for i_step, st in enumerate(steps(path)):
        if i_step < skip:
            continue
        # the tail: from the first traced iteration whose predecessor moved <= T (the first traced
        # iteration's predecessor is an edge pass, untraced: its candidate count stands in)
        start = None
        prev_moved = len(st[0][1])
        for j, (k, cands) in enumerate(st):
            if prev_moved <= T:
                start = j
                break
            prev_moved = sum(m for _, m, _ in cands)
        if start is None:
            continue
        tail = st[start:]
        cand = set(v for _, cs in tail for v, _, _ in cs)
        if not cand:
            continue
        moves = set(v for _, cs in tail for v, m, _ in cs if m)
        nbrs = {v: nb for _, cs in tail for v, _, nb in cs}
        p = {v: v for v in cand | moves}
        for v in cand:
            for u in nbrs[v]:
                if u in moves or (v in moves and u in cand):
                    if u not in p:
                        p[u] = u
                    a, b = find(p, v), find(p, u)
                    if a != b:
                        p[a] = b
        comp = defaultdict(set)
        for v in cand:
            comp[find(p, v)].add(v)
        # groups of the first tail iteration's candidates (the same rule, that iteration alone)
        first = set(v for v, _, _ in tail[0][1])
        q = {v: v for v in first}
        for v in first:
            for u in nbrs[v]:
                if u in first:
                    a, b = find(q, v), find(q, u)
                    if a != b:
                        q[a] = b
        merged = sum(1 for c in comp.values() if len({find(q, v) for v in c if v in first}) > 1)
        per_iter_max = max(max(sum(1 for v, _, _ in cs if find(p, v) == r) for _, cs in tail) for r in comp)
        active = []
        for r in comp:
            its = [j for j, (_, cs) in enumerate(tail) if any(find(p, v) == r for v, _, _ in cs)]
            active.append(its[-1] - its[0] + 1)
        listed = set(v for v, _, _ in tail[0][1])
        region = set(listed) | set(u for v in listed for u in nbrs[v])
        for _, cs in tail[1:]:
            new_lists = [v for v, _, _ in cs if v not in listed]
            new_pos = set(u for v in new_lists for u in nbrs[v] if u not in region) | set(v for v in new_lists if v not in region)
            loads.append((len(cs), len(new_lists), len(new_pos)))
            listed |= set(new_lists)
            region |= new_pos
        rows.append((len(tail), len(comp), max(len(c) for c in comp.values()), per_iter_max, merged,
                     sorted(active)[len(active) // 2], len(cand)))
    n = len(rows)
    def mean(i):
        return sum(r[i] for r in rows) / n
    def share(pred):
        return sum(1 for r in rows if pred(r)) / n
    print(f"{path}: {n} steps with a tail (T = {T})")
    print(f"  tail iterations a step: mean {mean(0):.2f}, max {max(r[0] for r in rows)}")
    print(f"  candidates in the tail (distinct): mean {mean(6):.1f}")
    print(f"  groups a step: mean {mean(1):.1f}; largest group (particles over the tail): mean {mean(2):.1f}, max {max(r[2] for r in rows)}")
    print(f"  a group's candidates in one iteration, largest: mean {mean(3):.1f}, max {max(r[3] for r in rows)}; steps where it exceeds 32: {share(lambda r: r[3] > 32):.1%}")
    print(f"  groups that merged (held candidates of several first-iteration groups): mean {mean(4):.2f} a step; steps with any: {share(lambda r: r[4] > 0):.1%}")
    print(f"  a group's active iterations, median group: mean {mean(5):.2f} (the tail's own: {mean(0):.2f})")
    nl = len(loads)
    print(f"  later tail iterations ({nl}): candidates mean {sum(l[0] for l in loads) / nl:.1f}; "
          f"not yet listed {sum(l[1] for l in loads) / nl:.2f}; positions not yet in the region {sum(l[2] for l in loads) / nl:.2f}; "
          f"iterations that load nothing: {sum(1 for l in loads if l[1] == 0 and l[2] == 0) / nl:.1%}")


main()
