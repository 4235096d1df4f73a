"""What every part of tools/render shares: the program's messages and exit codes, the labels of
the quantities it knows (in flipflow's reduced units), the run's pipeline as the file records it
(σ, diameters, walls), titles that fit the figure, and saving a figure."""
import os
import re
import sys


PROG = "render"


# Axis and colour-bar labels of the quantities render knows, by the last part of their name
# (observe.msd/msd: msd), in flipflow's reduced units: lengths in σ, time in τ (σ²/D of the
# Brownian pipelines, τ_B of Tran's), energies in k_BT. Other names are labelled as they are.
QUANTITY_LABELS = {
    "time": "t / τ",
    "boids_time": "t (steps of the boids' map, Δt = 1)",
    "dt": "Δt / τ",
    "dt_max": "largest stable Δt / τ",
    "r/σ": "r / σ",
    "msd": "MSD ⟨Δr²⟩ / σ²",
    "g": "g(r)",
    "g_contact": "contact value g(σ⁺)",
    "Z": "Z = βP/ρ",
    "voronoi.area": "cell area / σ²",
    "area_mean": "mean cell area / σ²",
    "area_variance": "cell area variance / σ⁴",
    "voronoi.sides": "cell sides",
    "sides_variance": "variance of cell sides",
    "pair.energy": "pair energy ½ Σ_j U_ij / k_BT",
    "pair.virial": "pair virial ½ Σ_j r_ij·F_ij / k_BT",
    "trap.energy": "trap energy k/2 |x − c|² / k_BT",
    "aggregates": "aggregates N_agg",
    "clusters": "clusters",
    "monomers": "monomers",
    "largest": "particles in the largest cluster",
    "largest_fraction": "largest cluster / particles",
    "mean_aggregate_size": "mean aggregate size",
    "coordination": "coordination number",
    "max_move": "largest move / σ",
}


# Quantities in powers of the box's length unit whose labels say σ: render divides them by
# system.sigma to that power, so the label holds whatever the run's sigma was (lengths are box
# units; σ is that unit only when system.sigma = 1, README "Units").
SIGMA_POWERS = {"msd": 2, "voronoi.area": 2, "area_mean": 2, "area_variance": 4}


def in_sigma_units(name, values, sigma):
    """values of quantity `name` in units of σ (SIGMA_POWERS), unchanged for other names."""
    power = SIGMA_POWERS.get(name, SIGMA_POWERS.get(name.strip("/").split("/")[-1]))
    return values / sigma ** power if power and sigma != 1.0 else values


# The legends of categories (species, cluster.label, touched) sit to the right of the box, outside
# it: inside they covered the particles of a corner.
LEGEND_BESIDE = dict(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize="small",
                     framealpha=0.8)


def quantity_label(name):
    """The readable label of a quantity (QUANTITY_LABELS), else its name."""
    return QUANTITY_LABELS.get(name, QUANTITY_LABELS.get(name.strip("/").split("/")[-1], name))


class InputProblem(Exception):
    pass


def fail(msg, code=2):
    print(f"{PROG}: {msg}", file=sys.stderr)
    sys.exit(code)


def import_libs():
    missing = []
    mods = {}
    for name in ("numpy", "h5py", "matplotlib"):
        try:
            mods[name] = __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        fail(f"{sys.executable} lacks the Python package(s) {', '.join(missing)} "
             f"(Debian: apt-get install {' '.join('python3-' + m for m in missing)})", 3)
    mods["matplotlib"].use("Agg")
    return mods["numpy"], mods["h5py"]


def did_you_mean(name, options):
    """' did you mean 'X'?' for a mistyped name among options, or ''. A name that is the last
    part of options ('msd' of observe.msd/msd) is matched by that part."""
    import difflib
    options = list(dict.fromkeys(options))
    same_tail = [o for o in options if o.split("/")[-1] == name]
    close = same_tail or difflib.get_close_matches(name, options, n=3, cutoff=0.6) or [
        o for o in options if o.split("/")[-1] in difflib.get_close_matches(name, [o.split("/")[-1] for o in options],
                                                                            n=3, cutoff=0.75)][:3]
    return f"did you mean {' or '.join(repr(c) for c in close[:3])}? " if close else ""


def need(f, path, what):
    """f[path], or an InputProblem naming the file and the missing path."""
    if path not in f:
        # Say which part of the path exists, to make the message useful.
        parts = path.strip("/").split("/")
        have = ""
        for p in parts:
            if have + "/" + p not in f:
                break
            have += "/" + p
        where = f"; the file has {have or '/'} with {sorted(f[have or '/'].keys())}" if have or parts else ""
        # A run that writes its curves and its frames to two files (the Tran pipelines' X.h5 and
        # X-frames.h5): point at the other one.
        other = ""
        if path.startswith("/particles/all/position"):
            stem, ext = os.path.splitext(f.filename)
            if os.path.exists(stem + "-frames" + ext):
                other = f"; the positions of this run are in {stem}-frames{ext}"
        raise InputProblem(f"{f.filename}: no {path} ({what}){where}{other}")
    return f[path]


def pipeline_text(f):
    """The pipeline the run ran, or None: /parameters/effective_pipeline (with the run's --set
    overrides applied: `--set system.sigma=2`, `--set step.overlap_correct.walls=x`), else, in
    files written before it was stored, /parameters/pipeline (the file as written)."""
    for where in ("parameters/effective_pipeline", "parameters/pipeline"):
        if where in f:
            raw = f[where][()]
            return raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)
    return None


def pipeline_walls(f):
    """The axis (0 or 1) of the hard walls of the run's pipeline (overlap_correct's `walls: y`
    or `walls: {axis: y}`), or None."""
    text = pipeline_text(f)
    if text is None:
        return None
    m = re.search(r"\bwalls:\s*(?:\{\s*axis:\s*)?([xy])\b", text)
    return "xy".index(m.group(1)) if m else None


def species_diameters(f, n_species):
    """Per-species diameters from the run's pipeline text (sigma * types[k].diameter)."""
    text = pipeline_text(f)
    if text is None:
        return None
    system = None
    try:
        import yaml  # optional
        doc = yaml.safe_load(text)
        system = doc.get("system") if isinstance(doc, dict) else None
    except Exception:
        system = None
    if isinstance(system, dict):
        sigma = float(system.get("sigma", 1.0))
        types = system.get("types") or []
        if types:
            return [sigma * float(t.get("diameter", 1.0)) for t in types]
        return [sigma] * max(n_species, 1)
    # No PyYAML: the flow-style `sigma: x` and `diameter: y` keys are all render needs.
    m = re.search(r"\bsigma:\s*([0-9.eE+-]+)", text)
    sigma = float(m.group(1)) if m else 1.0
    ds = [float(x) for x in re.findall(r"\bdiameter:\s*([0-9.eE+-]+)", text)]
    return [sigma * d for d in ds] if ds else [sigma] * max(n_species, 1)


def pipeline_sigma(f):
    """system.sigma of the run's pipeline (the length unit σ), else 1."""
    text = pipeline_text(f)
    m = re.search(r"\bsigma:\s*([0-9.eE+-]+)", text) if text is not None else None
    try:
        return float(m.group(1)) if m and float(m.group(1)) > 0 else 1.0
    except ValueError:
        return 1.0


def fit_title(fig, ax, title):
    """ax's title, wrapped (at its ", " or else its spaces) and if need be shrunk to fit the figure,
    then the layout fitted. A title wider than the figure is cut at both edges (the default title
    of a 3D frame or of several files' curves is): matplotlib neither wraps nor shrinks it."""
    fig.tight_layout()
    t = ax.set_title(title, fontsize="medium")
    renderer = fig.canvas.get_renderer()
    # The title is centred on the axes: it fits when each half fits between the axes' centre and
    # the nearer edge of the figure (a colour bar moves the centre left).
    box = ax.get_position()
    centre = 0.5 * (box.x0 + box.x1)
    room = 0.96 * 2 * min(centre, 1 - centre) * fig.get_figwidth() * fig.dpi

    def width():
        return t.get_window_extent(renderer).width

    if width() > room and "\n" not in title:
        sep = ", " if ", " in title else " "
        pieces = title.split(sep)
        lines = [pieces[0]]
        for piece in pieces[1:]:
            t.set_text(lines[-1] + sep + piece)
            if width() <= room:
                lines[-1] += sep + piece
            else:
                lines[-1] += sep.rstrip()
                lines.append(piece)
        t.set_text("\n".join(lines))
    # A piece wider than the figure alone (a long file name): a smaller font, down to 6 pt.
    while width() > room and t.get_fontsize() > 6:
        t.set_fontsize(t.get_fontsize() - 0.5)
    fig.tight_layout()


def save(fig, out, args):
    import matplotlib.pyplot as plt
    if args.palette:
        # An indexed-colour PNG: a few times smaller, for figures kept in the repository.
        import io
        from PIL import Image
        buf = io.BytesIO()
        fig.savefig(buf, dpi=args.dpi, format="png")
        buf.seek(0)
        Image.open(buf).convert("RGB").quantize(colors=args.palette).save(out, format="PNG", optimize=True)
    else:
        fig.savefig(out, dpi=args.dpi)
    plt.close(fig)


def default_out(path, suffix):
    stem = os.path.splitext(path)[0]
    if stem.endswith(".h5"):
        stem = stem[:-3]
    return f"{stem}-{suffix}.png"
