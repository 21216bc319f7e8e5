#!/usr/bin/env python3
"""The paper's per-bond yield law (Eq 12-15, each bond's deviatoric force capped at ±A_c) read in the
continuum, for a bar in uniaxial tension (issue 12.3; accuracy.md, "What the 0.2 % offset reads").

    /usr/bin/python3 assets/report/yield_knee.py [--plot assets/report/images/yield_knee.png]

Bonds in every direction n of a full isotropic family carry the deviatoric strain s(n) = n·ε_d·n − p(n),
p(n) the bond's plastic part, capped at ±s_c; the stress is κ tr ε I + (15μ/4π) ∫ s(n) n⊗n dΩ (which is
2μ ε_d while every bond is elastic) and the lateral strain is solved so that σ_yy = σ_zz = 0. The
full-flow stress, every bond at ±s_c with the sign of 3cos²−1, is σ_p = 10 μ s_c/√3: what perifx sets
A_c from (systems/model_constants.cpp). Bonds reach the cap one direction at a time, the axial ones
first, so the curve bends from about σ_p/2 and has no sharp yield point. The script prints, against
σ_p/E, the stress at the engineering 0.2 % plastic offset as a fraction of σ_p, and the flow stress at
2.5, 5 and 10 times σ_p/E. systems/yield_law.cpp computes the same law in C++ (offset_yield_ratio,
which `perifx info` prints); tests/systems/test_yield_law.cpp checks it against this script's numbers.
"""
import sys

import numpy as np

KAPPA, MU = 3.3e6, 2.0e6  # the long bar test's material (ν = 0.248)
E = 9 * KAPPA * MU / (3 * KAPPA + MU)
C = -1 + (np.arange(4000) + 0.5) * (2 / 4000)  # cos of the angle to the bar's axis, midpoints
PREF = 15 * MU / (4 * np.pi) * 2 * np.pi * (2 / 4000)


def curve(flow_stress, strain_max, increments=4000):
    s_c = np.sqrt(3) * flow_stress / (10 * MU)
    p = np.zeros_like(C)

    def stresses(exx, eyy):
        tr = exx + 2 * eyy
        s = (exx - tr / 3) * C**2 + (eyy - tr / 3) * (1 - C**2) - p
        capped = np.clip(s, -s_c, s_c)
        return (KAPPA * tr + PREF * np.sum(capped * C**2), KAPPA * tr + PREF * np.sum(capped * (1 - C**2) / 2),
                s - capped)

    eyy, out = 0.0, []
    for exx in np.linspace(strain_max / increments, strain_max, increments):
        for _ in range(20):  # secant on σ_yy = 0
            h = 1e-6 * flow_stress / E
            f0, f1 = stresses(exx, eyy)[1], stresses(exx, eyy + h)[1]
            eyy -= f0 * h / (f1 - f0)
            if abs(f0) < 1e-12 * flow_stress:
                break
        sxx, _, excess = stresses(exx, eyy)
        p += excess
        out.append((exx, sxx))
    return np.array(out)


def offset_yield(strain, stress, offset=0.002):
    gap = stress - E * (strain - offset)
    k = int(np.argmax(gap <= 0))
    f = gap[k - 1] / (gap[k - 1] - gap[k])
    return stress[k - 1] + f * (stress[k] - stress[k - 1])


def main():
    print("| σ_p/E | 0.2 % offset yield / σ_p | flow at 2.5 / 5 / 10 σ_p/E (/ σ_p) |")
    print("|---|---|---|")
    curves = {}
    for eps_y in (0.00125, 0.0025, 0.004, 0.01):
        r = curve(eps_y * E, 12 * eps_y + 0.004)
        curves[eps_y] = r
        at = lambda x: r[int(np.argmax(r[:, 0] >= x)), 1] / (eps_y * E)
        print(f"| {100 * eps_y:g} % | {offset_yield(r[:, 0], r[:, 1]) / (eps_y * E):.4f} | "
              f"{at(2.5 * eps_y):.4f} / {at(5 * eps_y):.4f} / {at(10 * eps_y):.4f} |")
    if "--plot" in sys.argv:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(6, 4))
        # In units of σ_p/E the curve is one curve for every ratio; the 0.2 % offset line is not: it
        # sits 0.002/(σ_p/E) to the right, further along the knee the stiffer the material.
        eps_y, r = 0.004, curves[0.004]
        ax.plot(r[:, 0] / eps_y, r[:, 1] / (eps_y * E), "k-", label="per-bond law (any σ_p/E)")
        for (ratio, colour) in ((0.00125, "tab:blue"), (0.004, "tab:green"), (0.01, "tab:red")):
            shift = 0.002 / ratio
            xs = np.array([shift, shift + 1.2])
            ax.plot(xs, xs - shift, "--", color=colour, lw=1,
                    label=f"0.2 % offset, σ_p/E = {100 * ratio:g} %: yield {offset_yield(curves[ratio][:, 0], curves[ratio][:, 1]) / (ratio * E):.3f} σ_p")
        ax.axhline(1.0, color="gray", lw=0.5)
        ax.set_xlim(0, 6)
        ax.set_ylim(0, 1.1)
        ax.set_xlabel("strain / (σ_p/E)")
        ax.set_ylabel("stress / σ_p")
        ax.set_title("Per-bond yield law in uniaxial tension (continuum)")
        ax.legend(fontsize=8, loc="lower right")
        fig.tight_layout()
        fig.savefig(sys.argv[sys.argv.index("--plot") + 1], dpi=110)


if __name__ == "__main__":
    main()
