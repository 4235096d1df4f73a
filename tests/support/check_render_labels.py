"""tools/render's labels and titles, which show only in the image: its functions called directly.

  check_render_labels.py RENDER      # RENDER: the path of tools/render

Prints "ok labels" or exits 1 naming what is wrong.
"""
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def fail(msg):
    print(f"FAILED: {msg}")
    sys.exit(1)


def load(path):
    """tools/render's parts (tools/render_lib beside the script) as one namespace."""
    import os
    import types
    sys.path.insert(0, os.path.dirname(os.path.realpath(path)))
    from render_lib import common, plots
    names = dict(vars(common))
    names.update(vars(plots))
    return types.SimpleNamespace(**names)


def title_fits(r, title, width_in):
    """fit_title on a figure of width_in inches with a colour bar: the title's lines and its size."""
    fig, ax = plt.subplots(figsize=(width_in, width_in * 0.8), dpi=80)
    fig.colorbar(matplotlib.cm.ScalarMappable(), ax=ax)
    r.fit_title(fig, ax, title)
    t = ax.title
    renderer = fig.canvas.get_renderer()
    box = t.get_window_extent(renderer)
    fig_px = fig.get_figwidth() * fig.dpi
    inside = box.x0 >= -0.5 and box.x1 <= fig_px + 0.5
    lines = t.get_text().split("\n")
    size = t.get_fontsize()
    plt.close(fig)
    return inside, lines, size


def main():
    r = load(sys.argv[1])
    # A 3D frame's default title on a narrow figure: wrapped at ", " and inside the figure.
    long_title = ("trajectory-with-a-long-name.h5, N = 60000, step 1987100, t = 19.871, "
                  "box 87.2 × 87.2 × 87.2, projection along z")
    inside, lines, size = title_fits(r, long_title, 4.0)
    if not inside:
        fail(f"a long title is cut at the figure's edges: {lines}")
    if len(lines) < 2:
        fail(f"a long title on a 4-inch figure was not wrapped: {lines}")
    if any(not line.strip() for line in lines) or "".join(lines).replace(",", "").replace(" ", "") != \
            long_title.replace(",", "").replace(" ", ""):
        fail(f"wrapping lost or changed words: {lines}")
    # A short title is left alone, at its size.
    inside, lines, size_short = title_fits(r, "abp.h5, step 5000", 6.0)
    if lines != ["abp.h5, step 5000"] or not inside:
        fail(f"a short title was changed: {lines}")
    # One unbreakable piece wider than the figure: a smaller font, down to 6 pt.
    inside, lines, size = title_fits(r, "x" * 120, 3.0)
    if size >= size_short or size < 6:
        fail(f"an unbreakable title kept font size {size} (short title: {size_short})")
    # Quantities are labelled in words with their units; unknown names stay as they are.
    for name, want in [("observe.clusters/aggregates", "aggregates N_agg"), ("max_move", "largest move / σ"),
                       ("observe.msd/msd", "MSD ⟨Δr²⟩ / σ²"), ("no.such/thing", "no.such/thing")]:
        got = r.quantity_label(name)
        if got != want:
            fail(f"quantity_label({name!r}) = {got!r}, expected {want!r}")
    # An observable's time axis: t / τ, but steps of the map for a boids run (Δt = 1 is one step).
    import os
    import tempfile

    import h5py
    import numpy as np
    with tempfile.TemporaryDirectory() as d:
        for stage, want in [("boids.integrate", "t (steps of the boids' map, Δt = 1)"), ("abp.integrate", "t / τ")]:
            path = os.path.join(d, stage + ".h5")
            with h5py.File(path, "w") as f:
                f["parameters/effective_pipeline"] = f"step:\n  - {{stage: {stage}}}\n"
                f["observables/phi/value"] = np.array([0.1, 0.2])
                f["observables/phi/time"] = np.array([0.0, 1.0])
            _, _, xlabel = r.h5_series(np, h5py, path, "phi")
            if r.quantity_label(xlabel) != want:
                fail(f"the time axis of a run of {stage}: {r.quantity_label(xlabel)!r}, expected {want!r}")
    # Curves from files of one name are told apart by their folders.
    labels = r.curve_labels(["/a/run1/gr.csv", "/a/run2/gr.csv"])
    if labels != ["run1/gr.csv", "run2/gr.csv"]:
        fail(f"curve_labels of two gr.csv: {labels}")
    if r.curve_labels(["/a/x.h5", "/b/y.h5"]) != ["x", "y"]:
        fail("curve_labels of distinct names")
    print("ok labels")


main()
