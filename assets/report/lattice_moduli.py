#!/usr/bin/env python3
"""Effective elastic moduli of an interior particle of the structured mesher's lattice under the
`discrete` constants (issue 12; accuracy.md, "The interior of the structured lattice"). Usage:

    /usr/bin/python3 assets/report/lattice_moduli.py [--plot assets/report/images/lattice_moduli.png]

The structured mesher cuts every grid cube into the six Freudenthal tets around one body diagonal and
puts a particle at each tet's barycentre (volume 1/6 of a cube). In an unbounded block every particle
of one of the six kinds has the same family, so a uniform strain field gives each kind one stress; this
script evaluates the linearized bond force of systems/README.md §2 (A = 4ωaθ + 4ωb e^d, ω = δ/|ξ|, the
`discrete` a, b, β and θ scale from the family's own sums, §2.4) for such fields, averages the six
kinds' virial stresses, and solves for the uniaxial-stress state (lateral strain chosen so that the
lateral stress vanishes). It prints, against the horizon δ in cell edges, the Young's modulus and
Poisson ratio the lattice shows as a fraction of the material's (E = 1, ν = 0.25), for

  * `sharp`: a neighbour is in the family when |ξ| ≤ δ (what perifx does), and
  * `partial h`: a neighbour's volume counts with the fraction of a slab of thickness h around the
    horizon that lies inside it, clamp((δ + h/2 − |ξ|)/h, 0, 1), for h = 1 and 2 particle spacings
    (spacing (1/6)^(1/3) cell edges): the usual partial-volume correction, which takes bonds out to δ + h/2.

Units: lengths in cell edges; the default horizon is 1.45 λ with λ the mesh's mean edge length, which
for a cube grid tends to (3 + 3√2 + √3)/7 ≈ 1.283 cell edges (the 7 unique edges a cube adds) and is a
little shorter in a small or thin body, whose surface holds more axis edges."""
import itertools
import math
import sys

import numpy as np

PERMUTATIONS = [(0, 1, 2), (1, 2, 0), (2, 0, 1), (0, 2, 1), (2, 1, 0), (1, 0, 2)]
VOLUME = 1.0 / 6.0                      # one tet of a unit cube
SPACING = VOLUME ** (1.0 / 3.0)         # cube root of a particle's volume, cell edges
NU = 0.25


def barycentres():
    """The six Freudenthal tets' barycentres in the unit cube (corner → +e_a → +e_b → +e_c)."""
    unit = np.eye(3)
    out = []
    for a, b, c in PERMUTATIONS:
        v1 = unit[a]
        v2 = v1 + unit[b]
        v3 = v2 + unit[c]
        out.append((v1 + v2 + v3) / 4.0)
    return np.array(out)


KINDS = barycentres()
REACH = 4
CELLS = np.array(list(itertools.product(range(-REACH, REACH + 1), repeat=3)), dtype=float)
LATTICE = (CELLS[:, None, :] + KINDS[None, :, :]).reshape(-1, 3)


def bonds_of(kind, radius):
    xi = LATTICE - KINDS[kind]
    r = np.linalg.norm(xi, axis=1)
    keep = (r > 1e-9) & (r <= radius)
    return xi[keep]


def mean_stress(strain, delta, ramp):
    """Mean over the six kinds of the virial stress of a uniform strain (E = 1, ν = NU)."""
    kappa = 1.0 / (3.0 * (1.0 - 2.0 * NU))
    mu = 1.0 / (2.0 * (1.0 + NU))
    stresses = []
    for kind in range(6):
        xi = bonds_of(kind, delta + ramp / 2.0)
        r = np.linalg.norm(xi, axis=1)
        n = xi / r[:, None]
        inside = np.clip((delta + ramp / 2.0 - r) / ramp, 0.0, 1.0) if ramp > 0 else np.ones_like(r)
        weight = delta / r * inside * VOLUME           # ω V_j, with the partial volume folded in
        m = (weight * r).sum()
        q = (weight * r * r).sum()
        mixed = [(weight * (xi[:, a] * xi[:, b]) ** 2 / r ** 2).sum() for a, b in ((0, 1), (1, 2), (2, 0))]
        a_const = 3.0 * kappa / (2.0 * m)
        b_const = mu / (2.0 * sum(mixed) / 3.0)
        beta = q / (3.0 * m)
        extension = r * np.einsum("ki,ij,kj->k", n, strain, n)
        theta = 3.0 / m * (weight * extension).sum()
        force_state = 4.0 * a_const * theta + 4.0 * b_const * (extension - beta * theta)
        stresses.append(0.5 * np.einsum("k,ki,kj->ij", weight * force_state * r, n, n))
    return np.mean(stresses, axis=0)


def uniaxial(delta, ramp=0.0):
    """(E_lattice / E, ν_lattice) for a stress along x."""
    along = mean_stress(np.diag([1.0, 0.0, 0.0]), delta, ramp)
    across = mean_stress(np.diag([0.0, 1.0, 1.0]), delta, ramp)
    lateral = -along[1, 1] / across[1, 1]
    return (along + lateral * across)[0, 0], -lateral


def bar_horizon(cells):
    """δ = 1.45 λ (cell edges) of the accuracy study's bar, 10n × n × n cubes."""
    nx, ny, nz = 10 * cells, cells, cells
    axis = nx * (ny + 1) * (nz + 1) + (nx + 1) * ny * (nz + 1) + (nx + 1) * (ny + 1) * nz
    face = nx * ny * (nz + 1) + nx * (ny + 1) * nz + (nx + 1) * ny * nz
    body = nx * ny * nz
    mean_edge = (axis + face * math.sqrt(2.0) + body * math.sqrt(3.0)) / (axis + face + body)
    return 1.45 * mean_edge


def main(argv):
    variants = [("sharp", 0.0), ("partial h", SPACING), ("partial 2h", 2.0 * SPACING)]
    print("| δ (cell edges) | family | " + " | ".join(f"{name} E / ν" for name, _ in variants) + " |")
    print("|---|---|" + "---|" * len(variants))
    deltas = np.round(np.arange(1.70, 2.3001, 0.025), 4)
    curves = {name: [] for name, _ in variants}
    for delta in deltas:
        cells = [uniaxial(delta, ramp) for _, ramp in variants]
        for (name, _), value in zip(variants, cells):
            curves[name].append(value)
        print(f"| {delta:.3f} | {len(bonds_of(0, delta))} | " +
              " | ".join(f"{e:.3f} / {nu:.3f}" for e, nu in cells) + " |")
    print()
    print("The accuracy study's bar (1.45 λ):")
    for cells in (4, 6, 8, 12):
        delta = bar_horizon(cells)
        e, nu = uniaxial(delta)
        print(f"  {cells:2d} cells: δ = {delta:.4f} cell edges, {len(bonds_of(0, delta))} bonds, "
              f"E {e:.3f}, ν {nu:.3f}")
    if "--plot" in argv:
        path = argv[argv.index("--plot") + 1]
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fine = np.round(np.arange(1.60, 2.4001, 0.005), 4)
        fig, ax = plt.subplots(figsize=(8, 4.2), dpi=110)
        for name, ramp in variants:
            ax.plot(fine, [uniaxial(d, ramp)[0] for d in fine], label=name, lw=1.4 if ramp else 1.0)
        for cells in (4, 6, 8, 12):
            ax.axvline(bar_horizon(cells), color="grey", lw=0.6, ls=":")
        ax.text(bar_horizon(4), 1.09, " 1.45 λ of the bar at 4–12 cells", fontsize=8, color="grey")
        ax.axhline(1.0, color="black", lw=0.5)
        ax.set_xlabel("horizon δ (cell edges of the structured grid)")
        ax.set_ylabel("Young's modulus of the lattice / E")
        ax.set_title("Interior of the structured lattice under `discrete` constants (ν = 0.25)", fontsize=10)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path)
        print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1:])
