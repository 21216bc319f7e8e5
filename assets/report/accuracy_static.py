#!/usr/bin/env python3
"""Tables and plots of the static accuracy study (issue 12) from the `ACCURACY {json}` lines that
tests/engine/accuracy/test_accuracy.cpp prints. Usage:

    python3 assets/report/accuracy_static.py LOG [LOG ...] [--plots DIR]

Prints markdown tables (reference convergence, PD errors) and, when matplotlib is available, writes
reference_convergence.png and pd_error.png into DIR (default assets/report/images)."""
import json
import math
import sys

A = 0.1                     # bar depth, m
TORQUE = 1e7 * 0.1 * A**4 / 6.0   # ∫ c (y² + z²) dV over the loaded slab (c = 1e7 N/m⁴)
J_SQUARE = 0.140577 * A**4  # Saint-Venant torsion constant of a square


def load(paths):
    rows = []
    for p in paths:
        for line in open(p, encoding="utf-8"):
            if line.startswith("ACCURACY "):
                # A failed solve prints its residual as C++'s `nan` (JSON: NaN); it is left out.
                row = json.loads(line[len("ACCURACY "):].replace(": nan", ": NaN"))
                if math.isnan(row.get("residual", 0.0)):
                    continue
                # A jittered mesh (PERIFX_ACCURACY_JITTER) is its own series beside the regular lattice.
                if row.get("jitter", 0.0) > 0.0:
                    row["normalization"] += f" jitter {row['jitter']:g}"
                rows.append(row)
    return rows


def richardson(hs, vs):
    """Extrapolate v(h) = v0 + c h^p from the last three points (any ratios): returns v0, p."""
    (h1, v1), (h2, v2), (h3, v3) = list(zip(hs, vs))[-3:]
    def f(p):  # (v1 - v2)/(v2 - v3) = (h1^p - h2^p)/(h2^p - h3^p)
        return (v1 - v2) * (h2**p - h3**p) - (v2 - v3) * (h1**p - h2**p)
    lo, hi = 0.3, 8.0
    if f(lo) * f(hi) > 0:
        return float("nan"), float("nan")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(lo) * f(mid) <= 0:
            hi = mid
        else:
            lo = mid
    p = 0.5 * (lo + hi)
    c = (v2 - v3) / (h2**p - h3**p)
    return v3 - c * h3**p, p


def main():
    args = sys.argv[1:]
    plots = "assets/report/images"
    if "--plots" in args:
        i = args.index("--plots")
        plots = args[i + 1]
        del args[i:i + 2]
    rows = load(args)
    ref = {}
    print("## Reference convergence\n")
    conv = {}
    for problem in ("cantilever", "torsion"):
        print(f"\n{problem}:\n\n| element | cells through depth | value |\n|---|---|---|")
        for solver in ("fem_t4", "fem_q10"):
            pts = sorted((r["cells"], r["value"]) for r in rows if r["solver"] == solver and r["problem"] == problem)
            if not pts:
                continue
            conv[(problem, solver)] = pts
            for n, v in pts:
                print(f"| {solver} | {n} | {v:.6g} |")
            if len(pts) >= 3:
                v0, p = richardson([A / n for n, _ in pts], [v for _, v in pts])
                conv[(problem, solver + "_extrapolated")] = v0
                print(f"| {solver}, Richardson (last 3, fitted order {p:.2f}) | ∞ | {v0:.6g} |")
        q = conv.get((problem, "fem_q10_extrapolated"))
        if q is not None:
            ref[problem] = q
    if "torsion" in ref:
        analytic = TORQUE / (20e6 * J_SQUARE)
        print(f"\nSaint-Venant twist rate T/(μJ) = {analytic:.6g} rad/m (Q10 extrapolated {ref['torsion']:.6g})")
    print("\n## PD errors against the reference\n")
    print("| normalization | δ/λ | cells | tip | twist | ν 0.1 | ν 0.25 | ν 0.4 | CG iterations (tip) |")
    print("|---|---|---|---|---|---|---|---|---|")
    pd = [r for r in rows if r["solver"] == "pd"]
    keys = sorted({(r["normalization"], r["horizon"], r["cells"]) for r in pd}, key=lambda k: (k[0], k[1], k[2]))
    errors = {}
    for key in keys:
        cells = []
        it = ""
        for problem, nu in (("cantilever", None), ("torsion", None), ("stretch", 0.1), ("stretch", 0.25), ("stretch", 0.4)):
            match = [r for r in pd if (r["normalization"], r["horizon"], r["cells"]) == key and r["problem"] == problem
                     and (nu is None or abs(r["nu"] - nu) < 1e-9)]
            if not match:
                cells.append("—")
                continue
            v = match[-1]["value"]
            target = nu if nu is not None else ref.get(problem)
            if target is None:
                cells.append("—")
                continue
            e = v / target - 1.0
            errors.setdefault((key[0], key[1], problem if nu is None else f"nu{nu}"), []).append((key[2], e))
            cells.append(f"{100 * e:+.1f}%")
            if problem == "cantilever":
                it = str(match[-1]["iterations"])
        print(f"| {key[0]} | {key[1]} | {key[2]} | " + " | ".join(cells) + f" | {it} |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("\n(matplotlib not available: no plots)")
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, problem in zip(axes, ("cantilever", "torsion")):
        for solver, mark in (("fem_t4", "o-"), ("fem_q10", "s-")):
            pts = conv.get((problem, solver))
            if pts:
                ax.plot([n for n, _ in pts], [abs(v) for _, v in pts], mark, label=solver)
        if problem in ref:
            ax.axhline(abs(ref[problem]), color="k", ls="--", lw=0.8, label="Q10 Richardson")
        ax.set_xlabel("cells through the depth")
        ax.set_ylabel("|tip deflection| (m)" if problem == "cantilever" else "twist rate (rad/m)")
        ax.set_title(problem)
        ax.legend()
    fig.tight_layout()
    fig.savefig(f"{plots}/reference_convergence.png", dpi=110)
    fig, axes = plt.subplots(1, 5, figsize=(18, 3.8), sharey=True)
    for ax, m in zip(axes, ("cantilever", "torsion", "nu0.1", "nu0.25", "nu0.4")):
        for (norm, hz, prob), pts in sorted(errors.items()):
            if prob != m:
                continue
            pts.sort()
            ax.plot([n for n, _ in pts], [100 * abs(e) for _, e in pts], "o-", label=f"{norm} (δ={hz}λ)")
        ax.axhline(5, color="r", ls="--", lw=0.8)
        ax.axhline(2, color="g", ls="--", lw=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(m)
        ax.set_xlabel("cells through the depth")
    axes[0].set_ylabel("|error| vs converged reference (%)")
    axes[-1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(f"{plots}/pd_error.png", dpi=110)
    print(f"\nplots written to {plots}/reference_convergence.png and {plots}/pd_error.png")


if __name__ == "__main__":
    main()
