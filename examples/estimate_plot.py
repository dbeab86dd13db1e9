"""Notebook-style example: estimate the sun (Pd) and sky (Pa) of the bundled courtyard sequence
from Python and plot them against the scene's truth.

    pip install ./python                  # or, in a venv: maturin develop -m python/Cargo.toml
    python examples/estimate_plot.py [--sequence ldr] [--plot out/estimate.png]

Without matplotlib the values are printed only.
"""

# %% Set-up
import argparse
import csv
from datetime import datetime
from pathlib import Path

import heliar

REPO = Path(__file__).resolve().parents[1]
LUMA = (0.2126, 0.7152, 0.0722)  # Rec. 709 luminance, as heliar's plots


def luma(rgb):
    return sum(w * c for w, c in zip(LUMA, rgb)) if rgb is not None else float("nan")


ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("--scene", default=str(REPO / "scenes" / "courtyard"))
ap.add_argument("--sequence", default="hdr")
ap.add_argument("--plot", default=str(REPO / "out" / "estimate_python.png"))
args = ap.parse_args()

# %% Estimate every frame (the GIL is released while each frame is estimated)
scene = heliar.Scene.load(args.scene)
est = scene.estimator(sequence=args.sequence)
rows = []
for path, time in zip(scene.frame_files(args.sequence), scene.frame_times(args.sequence)):
    e = est.estimate(heliar.read_frame(path), time)
    rows.append(e)
    print(f"{Path(path).name}  {e.status:16s} Pd {luma(e.pd):7.3f} ± {luma(e.pd_se):.3f}  Pa {luma(e.pa):6.3f} ± {luma(e.pa_se):.3f}  cond {e.condition_number or float('nan'):.1f}")

# %% The truth the scene ships (truth.csv: frame,time,pd_r,pd_g,pd_b,pa_r,pa_g,pa_b)
truth_file = Path(args.scene) / "truth.csv"
truth = []
if truth_file.is_file():
    with truth_file.open() as f:
        for r in csv.DictReader(row for row in f if not row.startswith("#")):
            truth.append((luma([float(r[k]) for k in ("pd_r", "pd_g", "pd_b")]), luma([float(r[k]) for k in ("pa_r", "pa_g", "pa_b")])))

# %% Plot (matplotlib is optional)
try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot (pip install matplotlib)")
else:
    t0 = datetime.fromisoformat(rows[0].time)
    t = [(datetime.fromisoformat(e.time) - t0).total_seconds() for e in rows]
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(t, [luma(e.pd) for e in rows], "o-", label="Pd (sun)")
    ax.plot(t, [luma(e.pa) for e in rows], "s-", label="Pa (sky)")
    if truth:
        ax.plot(t, [p for p, _ in truth[: len(rows)]], "k--", lw=1, label="Pd true")
        ax.plot(t, [a for _, a in truth[: len(rows)]], "k:", lw=1, label="Pa true")
    ax.set_xlabel("time since first frame (s)")
    ax.set_ylabel("irradiance (luminance, scaled radiance units)")
    ax.set_title(f"{scene.name} / {args.sequence}: sun and sky estimated from the footage")
    ax.legend()
    fig.tight_layout()
    Path(args.plot).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.plot, dpi=120)
    print(f"wrote {args.plot}")
