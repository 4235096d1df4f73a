"""tools/render's plots: H5MD observables and CSV columns against time (or r for g(r)), the
cluster-size distribution of observe.clusters' cluster_sizes.csv, and --list."""
import math
import os
import re

from render_lib.common import (
    in_sigma_units, quantity_label, InputProblem, did_you_mean, pipeline_text, pipeline_sigma,
    fit_title, save, default_out)


def observable_names(f):
    names = []
    if "observables" in f:
        def visit(name, obj):
            if hasattr(obj, "keys") and "value" in obj:
                names.append(name)
        f["observables"].visititems(visit)
    return sorted(names)


def h5_series(np, h5py, path, name):
    """(t, values [samples, components], x label) of /observables/NAME in an H5MD file."""
    with h5py.File(path, "r") as f:
        key = name.strip("/")
        if key.startswith("observables/"):
            key = key[len("observables/"):]
        where = f"/observables/{key}/value"
        if where not in f:
            avail = observable_names(f)
            raise InputProblem(f"{path}: no {where} (observable '{name}'); {did_you_mean(key, avail)}observables in "
                               f"the file: " + (", ".join(avail) if avail else "none"))
        g = f[f"observables/{key}"]
        v = in_sigma_units(key, np.asarray(g["value"][()], dtype=float), pipeline_sigma(f))
        if "time" in g and g["time"].shape and g["time"].shape[0] == v.shape[0]:
            # A boid's Δt = 1 is one step of Porro et al.'s map, not a unit of a diffusion time.
            boids = re.search(r"\bstage:\s*boids\.integrate\b", pipeline_text(f) or "")
            t, xlabel = np.asarray(g["time"][()], dtype=float), "boids_time" if boids else "time"
        elif "step" in g and g["step"].shape and g["step"].shape[0] == v.shape[0]:
            t, xlabel = np.asarray(g["step"][()], dtype=float), "step"
        else:
            t, xlabel = np.arange(v.shape[0], dtype=float), "sample"
    return t, v.reshape(v.shape[0], -1) if v.ndim else v.reshape(1, 1), xlabel


def csv_table(path):
    """(column names, data lines, '#' comment lines) of a CSV file whose first line that is not a
    '#' comment names the columns."""
    with open(path) as f:
        text = [l.strip() for l in f if l.strip()]
    comments = [l for l in text if l.startswith("#")]
    lines = [l for l in text if not l.startswith("#")]
    if not lines:
        raise InputProblem(f"{path}: no header row (the file is empty or only comments)")
    return [c.strip() for c in lines[0].split(",")], lines[1:], comments


def csv_numbers(np, path, header, lines):
    """The data lines of a CSV file as numbers [rows, columns], or an InputProblem naming the file."""
    try:
        return np.asarray([[float(v) for v in l.split(",")] for l in lines], dtype=float).reshape(-1, len(header))
    except ValueError as e:
        raise InputProblem(f"{path}: a row is not numbers with {len(header)} columns ({e})")


def csv_series(np, path, name, x=None):
    """(x values, values [samples, 1], x label) of the column named by NAME's last part of a CSV
    file (observe.clusters' clusters.csv, observe.gr's gr.csv). x: the column --x names, else r
    (gr.csv's bin centres; in σ when a comment line gives the sigma), time or step, else the row."""
    column = name.strip("/").split("/")[-1]
    header, lines, comments = csv_table(path)
    if column not in header:
        raise InputProblem(f"{path}: no column '{column}' (observable '{name}'); {did_you_mean(column, header)}"
                           f"columns: {', '.join(header)}")
    if x is not None and x not in header:
        raise InputProblem(f"{path}: --x {x}: no such column; columns: {', '.join(header)}")
    rows = csv_numbers(np, path, header, lines)
    xcol = x or next((c for c in ("r", "time", "step") if c in header), None)
    if xcol is None:
        return np.arange(rows.shape[0], dtype=float), rows[:, [header.index(column)]], "sample"
    t = rows[:, header.index(xcol)]
    if xcol == "r":
        # observe.gr writes r in length units and σ in its first comment line: g(r) against r/σ.
        m = next((re.search(r"\bsigma = ([0-9.eE+-]+)", c) for c in comments if re.search(r"\bsigma = ", c)), None)
        if m and float(m.group(1)) > 0:
            return t / float(m.group(1)), rows[:, [header.index(column)]], "r/σ"
    return t, rows[:, [header.index(column)]], xcol


def size_table(np, path):
    """observe.clusters' cluster_sizes.csv in either layout as (steps [calls], sizes [m], counts
    [calls, m], K): wide (step, time, n1 ... n(K-1), nKplus; the last size column counts the
    clusters of K or more) or long (step, time, size, clusters; K None). None for another CSV."""
    header, lines, _ = csv_table(path)
    if header[:2] != ["step", "time"] or len(header) < 4:
        return None
    long = header[2:] == ["size", "clusters"]
    plus = re.fullmatch(r"n(\d+)plus", header[-1])
    if not long and not (plus and header[2:-1] == [f"n{k}" for k in range(1, int(plus.group(1)))]):
        return None
    rows = csv_numbers(np, path, header, lines)
    if not long:
        K = int(plus.group(1))
        return rows[:, 0], np.arange(1, K + 1), rows[:, 2:], K
    steps, call = np.unique(rows[:, 0], return_inverse=True)
    sizes, column = np.unique(rows[:, 2].astype(np.int64), return_inverse=True)
    counts = np.zeros((steps.size, sizes.size))
    np.add.at(counts, (call, column), rows[:, 3])
    return steps, sizes, counts, None


def plot_size_distribution(np, args, tables):
    """⟨N_n⟩ against n (log-log) for cluster_sizes.csv files, over their calls at --from-step and later."""
    import matplotlib.pyplot as plt
    labels = curve_labels(args.files)
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    lines = []
    for path, label, (steps, sizes, counts, K) in zip(args.files, labels, tables):
        keep = steps >= args.from_step
        if not keep.any():
            raise InputProblem(f"{path}: no call at step {args.from_step:g} or later (its calls: steps "
                               f"{steps[0]:g} to {steps[-1]:g})" if steps.size else f"{path}: no rows")
        mean = counts[keep].mean(axis=0)
        exact = sizes < K if K else np.ones(sizes.size, dtype=bool)
        # Sizes one by one up to 10, then ⟨N_n⟩ averaged over the integers of bins 1.25 times
        # wider each: a large cluster is seen in a call or two, and alone it would be a floor of
        # points at 1/calls.
        top = int(sizes[exact].max()) if exact.any() else 0
        dense = np.zeros(top)
        dense[sizes[exact] - 1] = mean[exact]
        edges = [1]
        while edges[-1] <= top:
            edges.append(edges[-1] + 1 if edges[-1] < 10 else max(edges[-1] + 1, int(round(edges[-1] * 1.25))))
        n_at, value = [], []
        for a, b in zip(edges[:-1], edges[1:]):
            b = min(b, top + 1)
            n_at.append(math.sqrt(a * (b - 1)))
            value.append(dense[a - 1:b - 1].mean())
        n_at, value = np.asarray(n_at), np.asarray(value)
        curve, = ax.plot(n_at[value > 0], value[value > 0], marker=".", linestyle="-", linewidth=0.8,
                         label=label if len(args.files) > 1 else None)
        particles = float((sizes[exact] * mean[exact]).sum())
        note = ""
        if K and mean[-1] > 0:
            ax.plot([K], [mean[-1]], marker=">", markersize=8, linestyle="none", color=curve.get_color(),
                    label=(f"{label}: " if len(args.files) > 1 else "") + f"n ≥ {K}")
            note = f" and {mean[-1]:.4g} clusters of {K} or more"
        present = exact & (mean > 0)
        largest = int(sizes[present].max()) if present.any() else 0
        lines.append(f"{path}: {int(keep.sum())} calls (steps {steps[keep][0]:g} to {steps[keep][-1]:g}), "
                     f"sizes 1 to {largest}" + (f" below {K}" if K else "") +
                     f"; particles a call in clusters of those sizes Σ n⟨N_n⟩ = {particles:.6g}{note}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cluster size n (particles)")
    ax.set_ylabel("⟨N_n⟩, clusters of size n a call")  # (binned above n = 10)
    ax.grid(alpha=0.3, which="both")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize="small")
    title = args.title if args.title is not None else (
        ", ".join(labels) + (f", steps ≥ {args.from_step:g}" if args.from_step > 0 else ""))
    fit_title(fig, ax, title)
    out = args.out or default_out(args.files[0], "distribution")
    save(fig, out, args)
    print(f"{out}: cluster-size distribution from {len(args.files)} file(s)")
    for line in lines:
        print("  " + line)


def curve_labels(paths):
    """Short names telling the files apart: their names, or with their folders when names repeat."""
    names = [os.path.basename(p) for p in paths]
    if len(set(names)) == len(names):
        return [os.path.splitext(n)[0] for n in names]
    return [os.path.join(os.path.basename(os.path.dirname(os.path.abspath(p))), n) for p, n in zip(paths, names)]


def plot_observables(np, h5py, args):
    import matplotlib.pyplot as plt
    logx = args.log in ("x", "xy")
    logy = args.log in ("y", "xy")
    labels = curve_labels(args.files)
    panels = []  # per observable: (name, x label, [(file label, t, v)])
    for name in args.plot_observable:
        curves, xlabel, unit_line = [], None, False
        for path, label in zip(args.files, labels):
            if path.endswith(".csv"):
                t, v, xl = csv_series(np, path, name, args.x)
                # g(r) (gr.csv's g against r): the ideal gas's g = 1 for reference.
                unit_line = unit_line or (name.strip("/").split("/")[-1] == "g" and xl in ("r", "r/σ"))
            else:
                t, v, xl = h5_series(np, h5py, path, name)
            # Samples a log axis cannot show (t = 0, the initial frame; values ≤ 0) are left out.
            keep = np.ones(t.shape[0], dtype=bool)
            if logx:
                keep &= t > 0
            if logy:
                keep &= (v > 0).all(axis=1)
            curves.append((label, t[keep], v[keep]))
            xlabel = xlabel or xl
        panels.append((name, xlabel, curves, unit_line))
    fig, axes = plt.subplots(len(panels), 1, figsize=(6.4, 3.2 * len(panels)), squeeze=False)
    for ax, (name, xlabel, curves, unit_line) in zip(axes[:, 0], panels):
        if unit_line:
            ax.axhline(1.0, color="0.4", linestyle="--", linewidth=0.8)
        for label, t, v in curves:
            for c in range(v.shape[1]):
                bits = ([label] if len(curves) > 1 else []) + ([f"component {c}"] if v.shape[1] > 1 else [])
                ax.plot(t, v[:, c], marker="." if v.shape[0] < 60 else None, label=", ".join(bits) or None)
        if logx:
            ax.set_xscale("log")
        if logy:
            ax.set_yscale("log")
        ax.set_xlabel(quantity_label(xlabel))
        ax.set_ylabel(quantity_label(name))
        ax.grid(alpha=0.3)
        if len(curves) > 1 or any(v.shape[1] > 1 for _, _, v in curves):
            ax.legend(fontsize="small")
    title = args.title if args.title is not None else ", ".join(labels)
    fit_title(fig, axes[0, 0], title)
    out = args.out or default_out(args.files[0], re.sub(r"[^A-Za-z0-9_.-]+", "_", "+".join(n for n, *_ in panels)))
    save(fig, out, args)
    scale = {"x": "log time axis", "y": "log value axis", "xy": "log-log axes"}.get(args.log, "linear axes")
    print(f"{out}: {', '.join(n for n, *_ in panels)} from {len(args.files)} file(s) "
          f"({', '.join(str(len(c[1])) for _, _, cs, _ in panels for c in cs)} samples; {scale}; "
          f"x: {', '.join(dict.fromkeys(quantity_label(xl) for _, xl, _, _ in panels))})")


def list_file(np, h5py, args):
    with h5py.File(args.file, "r") as f:
        if "particles/all" in f:
            for name, obj in f["particles/all"].items():
                shape = obj["value"].shape if hasattr(obj, "keys") and "value" in obj else getattr(obj, "shape", "")
                print(f"/particles/all/{name} {shape}")
        for name in observable_names(f):
            print(f"/observables/{name} {f['observables/' + name + '/value'].shape}")
