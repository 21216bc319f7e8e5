#!/usr/bin/env python3
"""Crack-tip speed of the glass traction scene (assets/scenes/glass_traction.json) from its damage field.

    python3 assets/report/loads_glass.py --critical-stretch          # s_c from G_c (the scene's value)
    python3 assets/report/loads_glass.py out/glass_traction [--png assets/report/images/loads_crack_speed.png] [--title T]

Reads every particles.NNNN.ply of the run (fields damage and displacement; reference = position -
displacement). A particle counts as cracked when its damage is at least 0.35 (a particle whose bonds to
one side are all cut sits near 0.5). The crack length a(t) is the largest reference distance of a
cracked particle from the notch tip (0, 0); the tip speed is the centred difference of a(t) over two
frame intervals. Branches are counted on vertical lines as separate runs of cracked particles.
Prints a markdown table and writes a CSV (and a PNG plot when matplotlib is installed).
"""
import math
import os
import re
import struct
import sys

E, NU, RHO, GC, DELTA = 72e9, 0.22, 2440.0, 3.8, 0.002
NOTCH_TIP = (0.0, 0.00013)
CRACKED = 0.35


def critical_stretch():
    mu = E / (2 * (1 + NU))
    return math.sqrt(GC / (5 * mu * DELTA)), mu


def wave_speeds():
    mu = E / (2 * (1 + NU))
    cs = math.sqrt(mu / RHO)
    # Rayleigh speed: root of (2 - x)^2 = 4 sqrt(1 - x k) sqrt(1 - x), x = (c/cs)^2, k = (cs/cp)^2.
    kappa = E / (3 * (1 - 2 * NU))
    cp = math.sqrt((kappa + 4 * mu / 3) / RHO)
    k = (cs / cp) ** 2
    lo, hi = 0.5, 0.99
    f = lambda x: (2 - x) ** 2 - 4 * math.sqrt(1 - x * k) * math.sqrt(1 - x)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(lo) * f(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return cp, cs, cs * math.sqrt(0.5 * (lo + hi))


TYPES = {"float": "f", "double": "d", "uchar": "B", "uint": "I", "int": "i", "ushort": "H", "short": "h",
         "float32": "f", "float64": "d", "uint8": "B", "uint32": "I", "int32": "i", "uint16": "H"}


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    names, fmt, count = [], "<", 0
    for line in header:
        tok = line.split()
        if tok[:2] == ["element", "vertex"]:
            count = int(tok[2])
        elif tok and tok[0] == "property":
            fmt += TYPES[tok[1]]
            names.append(tok[2])
    size = struct.calcsize(fmt)
    rows = [struct.unpack_from(fmt, data, end + i * size) for i in range(count)]
    return {n: [r[c] for r in rows] for c, n in enumerate(names)}


def analyse(run):
    frames = sorted(f for f in os.listdir(run) if re.fullmatch(r"particles\.\d+\.ply", f))
    if not frames:
        sys.exit(f"no particles.NNNN.ply in {run}")
    import json
    summary = json.load(open(os.path.join(run, "summary.json")))
    rate = None
    for key in ("frame_rate", "frames_per_second"):
        if key in summary:
            rate = summary[key]
    rate = rate or 1e6
    rows = []
    for name in frames:
        k = int(name.split(".")[1])
        p = read_ply(os.path.join(run, name))
        ref = [(x - ux, y - uy) for x, y, ux, uy in zip(p["x"], p["y"], p["displacement_x"], p["displacement_y"])]
        cracked = [r for r, d in zip(ref, p["damage"]) if d >= CRACKED and r[0] > NOTCH_TIP[0] - 0.001]
        a = max((math.hypot(x - NOTCH_TIP[0], y - NOTCH_TIP[1]) for x, y in cracked), default=0.0)
        tip = max(cracked, key=lambda r: math.hypot(r[0] - NOTCH_TIP[0], r[1] - NOTCH_TIP[1]), default=(0, 0))
        branches = []
        for xline in (0.01, 0.02, 0.03, 0.04):
            ys = sorted(y for x, y in cracked if abs(x - xline) < 0.0008)
            runs = 0
            for j, y in enumerate(ys):
                if j == 0 or y - ys[j - 1] > 0.003:
                    runs += 1
            branches.append(runs)
        rows.append({"frame": k, "time": k / rate, "length": a, "tip": tip, "branches": branches})
    for j, r in enumerate(rows):
        lo, hi = rows[max(0, j - 1)], rows[min(len(rows) - 1, j + 1)]
        r["speed"] = (hi["length"] - lo["length"]) / (hi["time"] - lo["time"]) if hi is not lo else 0.0
    return rows


def main():
    if "--critical-stretch" in sys.argv:
        sc, mu = critical_stretch()
        print(f"mu = E/(2(1+nu)) = {mu:.5g} Pa, delta = {DELTA} m, G_c = {GC} J/m^2: "
              f"s_c = sqrt(G_c/(5 mu delta)) = {sc:.5g}")
        return
    run = sys.argv[1]
    png = sys.argv[sys.argv.index("--png") + 1] if "--png" in sys.argv else None
    rows = analyse(run)
    cp, cs, cr = wave_speeds()
    print(f"wave speeds: c_p {cp:.0f} m/s, c_s {cs:.0f} m/s, Rayleigh c_R {cr:.0f} m/s")
    print("| t (µs) | crack length a (mm) | tip (x, y) mm | tip speed (m/s) | v/c_R | cracked runs at x = 10, 20, 30, 40 mm |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['time'] * 1e6:.0f} | {r['length'] * 1e3:.1f} | ({r['tip'][0] * 1e3:.1f}, {r['tip'][1] * 1e3:.1f}) | "
              f"{r['speed']:.0f} | {r['speed'] / cr:.2f} | {', '.join(map(str, r['branches']))} |")
    run_rows = [r for r in rows if 0.003 < r["length"] < 0.045]
    if len(run_rows) >= 2:
        ts, ls = [r["time"] for r in run_rows], [r["length"] for r in run_rows]
        mt, ml = sum(ts) / len(ts), sum(ls) / len(ls)
        slope = sum((t - mt) * (l - ml) for t, l in zip(ts, ls)) / sum((t - mt) ** 2 for t in ts)
        print(f"least-squares slope of a(t) while 3 mm < a < 45 mm ({ts[0] * 1e6:.0f}-{ts[-1] * 1e6:.0f} µs): "
              f"{slope:.0f} m/s ({slope / cr:.2f} c_R)")
    moving = [r["speed"] for r in rows if r["length"] > 0.003 and r["length"] < 0.045]
    if moving:
        print(f"mean tip speed while the crack runs (3 mm < a < 45 mm): {sum(moving) / len(moving):.0f} m/s "
              f"({sum(moving) / len(moving) / cr:.2f} c_R) over {len(moving)} frames; max {max(moving):.0f} m/s")
    with open(os.path.join(run, "crack_speed.csv"), "w") as f:
        f.write("time_s,crack_length_m,tip_speed_m_per_s\n")
        for r in rows:
            f.write(f"{r['time']:.9g},{r['length']:.6g},{r['speed']:.6g}\n")
    if png:
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            print("matplotlib is not installed: no plot")
            return
        t = [r["time"] * 1e6 for r in rows]
        fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax[0].plot(t, [r["length"] * 1e3 for r in rows], "o-", ms=3)
        ax[0].set_ylabel("crack length from notch tip (mm)")
        ax[0].grid(alpha=0.3)
        ax[1].plot(t, [r["speed"] for r in rows], "o-", ms=3, label="perifx tip speed (damage ≥ 0.35)")
        ax[1].axhspan(0.4 * cr, 0.6 * cr, color="tab:green", alpha=0.15, label=f"0.4–0.6 c_R (c_R = {cr:.0f} m/s)")
        ax[1].axhline(1500, color="tab:red", ls="--", label="glass, measured terminal speed ≈ 1500 m/s")
        ax[1].axhline(cr, color="gray", ls=":", label="Rayleigh speed c_R")
        ax[1].set_xlabel("time (µs)")
        ax[1].set_ylabel("tip speed (m/s)")
        ax[1].legend(fontsize=8, loc="upper right")
        ax[1].grid(alpha=0.3)
        title = sys.argv[sys.argv.index("--title") + 1] if "--title" in sys.argv else "Soda-lime glass plate under traction"
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(png, dpi=110)
        print(f"wrote {png}")
    if "--map" in sys.argv:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        out = sys.argv[sys.argv.index("--map") + 1]
        frames = sorted(f for f in os.listdir(run) if re.fullmatch(r"particles\.\d+\.ply", f))
        picks = [frames[len(frames) // 4], frames[len(frames) // 2], frames[-1]]
        fig, axes = plt.subplots(1, 3, figsize=(12, 2.6))
        for ax, name in zip(axes, picks):
            p = read_ply(os.path.join(run, name))
            x = [(a - u) * 1e3 for a, u in zip(p["x"], p["displacement_x"])]
            y = [(a - u) * 1e3 for a, u in zip(p["y"], p["displacement_y"])]
            sc = ax.scatter(x, y, c=p["damage"], s=0.6, cmap="inferno", vmin=0, vmax=0.6)
            ax.set_aspect("equal")
            ax.set_title(f"t = {int(name.split('.')[1])} µs (damage)", fontsize=9)
            ax.set_xticks([-50, 0, 50])
            ax.set_yticks([-20, 0, 20])
        fig.colorbar(sc, ax=axes, shrink=0.8)
        fig.savefig(out, dpi=110, bbox_inches="tight")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
