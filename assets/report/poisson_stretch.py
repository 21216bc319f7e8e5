#!/usr/bin/env python3
"""Lateral contraction of the stretched beams of paper Fig. 9, measured from a run's output.

    python3 assets/report/poisson_stretch.py RUN_DIR [RUN_DIR ...] [--scene SCENE.json] [--frames K]

RUN_DIR is a `perifx run` output directory (particles.pvd + particles.NNNN.vtu; peridynamic or FEM
runs alike). Every body is treated as a beam along x. For each body and each of the last K frames
(default 3) the script takes the points whose reference x lies in the middle of the beam
(|x - x_mid| <= 20% of the length, away from the gripped ends, where the velocity conditions hold
the cross-section at its reference size) and measures

    axial strain    e_x = (mean x of the points right of the middle - mean x left of it) / same at frame 0 - 1
                    (the two halves of the middle window, so rigid motion cancels)
    lateral strain  e_y = (mean y of the upper half - mean y of the lower half) / same at frame 0 - 1,
                    likewise e_z
Both are distances between the centroids of two halves of whole grid cells. The six tet-barycenter
particles of a cell also move relative to each other (non-affinely, by tet type), so a measure over
individual particles (an rms spread, a fitted slope) mixes that sub-cell motion in; whole-cell
centroids do not (exact when the window and the cross-section are whole numbers of cells, as in the
paper scenes: 6 cells across).

and reports the contraction ratio -e_lat / e_x (engineering strains; the small-strain Poisson
ratio) and -ln(1 + e_lat) / ln(1 + e_x) (logarithmic strains), with the nominal
nu = (3 kappa - 2 mu) / (2 (3 kappa + mu)) of the body's material when --scene names the scene.
Pure Python (no numpy): reads the binary appended VTU that perifx writes.
"""
import argparse
import json
import math
import os
import re
import struct

TYPES = {"Float64": "d", "Float32": "f", "UInt32": "I", "UInt16": "H", "UInt8": "B", "Int32": "i", "UInt64": "Q"}


def read_vtu(path, wanted=("points", "body_id")):
    """Arrays of a perifx particle VTU (raw appended data, UInt64 block headers) by name."""
    data = open(path, "rb").read()
    appended = data.index(b"<AppendedData")
    head = data[:appended].decode()
    n = int(re.search(r'NumberOfPoints="(\d+)"', head).group(1))
    base = data.index(b"_", appended) + 1
    points_lo, points_hi = head.find("<Points>"), head.find("</Points>")
    out = {}
    for m in re.finditer(r"<DataArray([^>]*)>", head):
        tag = m.group(1)
        name = "points" if points_lo <= m.start() <= points_hi else re.search(r'Name="([^"]*)"', tag).group(1)
        if name not in wanted:
            continue
        code = TYPES[re.search(r'type="([^"]*)"', tag).group(1)]
        comps = re.search(r'NumberOfComponents="(\d+)"', tag)
        comps = int(comps.group(1)) if comps else 1
        offset = base + int(re.search(r'offset="(\d+)"', tag).group(1))
        nbytes = struct.unpack_from("<Q", data, offset)[0]
        values = struct.unpack_from("<%d%s" % (nbytes // struct.calcsize(code), code), data, offset + 8)
        out[name] = [values[i * comps:(i + 1) * comps] for i in range(n)] if comps > 1 else list(values)
    return out


def frames(run):
    text = open(os.path.join(run, "particles.pvd")).read()
    out = []
    for tag in re.findall(r"<DataSet[^>]*>", text):
        t = float(re.search(r'timestep="([^"]*)"', tag).group(1))
        out.append((t, os.path.join(run, re.search(r'file="([^"]*)"', tag).group(1))))
    return out


def halves(points, idx, axis):
    """The indices below and above the mean reference coordinate along axis."""
    mean = sum(points[i][axis] for i in idx) / len(idx)
    return [i for i in idx if points[i][axis] < mean], [i for i in idx if points[i][axis] > mean]


def gap(points, halves_pair, axis):
    lo, hi = halves_pair
    return sum(points[i][axis] for i in hi) / len(hi) - sum(points[i][axis] for i in lo) / len(lo)


def nominal_nu(scene_file):
    """Body index -> (name, nominal nu) from the scene's materials."""
    scene = json.load(open(scene_file))
    out = {}
    for k, body in enumerate(scene["bodies"]):
        m = scene["materials"][body["material"]]
        if "bulk_modulus" in m:
            kappa, mu = m["bulk_modulus"], m["shear_modulus"]
            nu = (3 * kappa - 2 * mu) / (2 * (3 * kappa + mu))
        else:
            nu = m["poisson_ratio"]
        out[k] = (body.get("name", str(k)), nu)
    return out


def measure(run, last=3, window=0.2):
    series = frames(run)
    ref = read_vtu(series[0][1])
    bodies = sorted(set(ref["body_id"]))
    sel = {}
    for b in bodies:
        idx = [i for i, v in enumerate(ref["body_id"]) if v == b]
        xs = [ref["points"][i][0] for i in idx]
        lo, hi = min(xs), max(xs)
        mid, half = 0.5 * (lo + hi), window * (hi - lo)
        middle = [i for i in idx if abs(ref["points"][i][0] - mid) <= half]
        sel[b] = [halves(ref["points"], middle, axis) for axis in range(3)]

    def state(pts, b):
        return [gap(pts, sel[b][axis], axis) for axis in range(3)]

    ref_state = {b: state(ref["points"], b) for b in bodies}
    result = {b: [] for b in bodies}
    for t, f in series[-last:]:
        pts = read_vtu(f)["points"]
        for b in bodies:
            now = state(pts, b)
            result[b].append((t,) + tuple(n / r - 1 for n, r in zip(now, ref_state[b])))
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--scene", help="scene file, for body names and the nominal Poisson ratio")
    ap.add_argument("--frames", type=int, default=3, help="average over the last K frames (default 3)")
    a = ap.parse_args()
    names = nominal_nu(a.scene) if a.scene else {}
    print("| run | body | nominal nu | axial strain | lateral strain y, z | -e_lat/e_x | log-strain ratio |")
    print("|---|---|---|---|---|---|---|")
    for run in a.runs:
        for b, rows in measure(run, a.frames).items():
            ex = sum(r[1] for r in rows) / len(rows)
            ey = sum(r[2] for r in rows) / len(rows)
            ez = sum(r[3] for r in rows) / len(rows)
            lat = 0.5 * (ey + ez)
            ratio = -lat / ex
            log_ratio = -math.log1p(lat) / math.log1p(ex)
            name, nu = names.get(b, (str(b), float("nan")))
            print(f"| {run} | {name} | {nu:.3f} | {100 * ex:.2f}% | {100 * ey:.2f}%, {100 * ez:.2f}% | "
                  f"{ratio:.3f} | {log_ratio:.3f} |")


if __name__ == "__main__":
    main()
