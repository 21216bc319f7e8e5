#!/usr/bin/env python3
"""Does the preview predict the final? (issue 12.5, assets/report/accuracy.md). For each paper scene
pair it runs the preview and the full scene over the time both cover and reports, side by side:

* motion deviation: `perifx compare FULL PREVIEW` (the full run's particle motion fitted at the
  preview's particles, per frame, over the full run's bounding-box diagonal; the paper's measure),
  mean and max over the frames both runs wrote;
* fracture onset: summary.json's `first_break_time` (the end of the step in which a bond first broke)
  when both runs have it, else the first frame time at which any bond has broken (runs before
  2026-12-03; one frame's resolution);
* fragments at the end (summary.json; every piece, single-particle dust included, so it grows with
  the particle count), the pieces holding at least 1 % of the mass (a count that can agree across
  resolutions) and the mass fraction of the largest piece (last frame's fragment_id and mass).

    python3 assets/report/preview_vs_final.py [--perifx build/perifx] [--threads 2]
        [--normalization corrected] [--work DIR] [--reuse] fig11_bar_swing fig12_bar_twist ...

--normalization runs both scenes of each pair with that model instead of the one they name (the paper
scenes choose `paper`; the previews of Fig. 10-13 choose `discrete`). Prints one markdown row per pair
and a JSON line with the numbers. --reuse takes a run whose summary.json is already in the work
directory (from the same scene copy) instead of running it again."""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from poisson_stretch import read_vtu  # noqa: E402  (the project's one Python VTU reader)

PAPER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "paper")


def frames(run):
    names = sorted(f for f in os.listdir(run) if f.startswith("particles.") and f.endswith(".vtu"))
    return [os.path.join(run, f) for f in names]


def scene_copy(name, variant, duration, normalization, work):
    path = os.path.join(PAPER, f"{name}.{variant}.json")
    s = json.load(open(path))
    for b in s["bodies"]:
        g = b["geometry"]
        if "path" in g:
            g["path"] = os.path.join(os.path.abspath(PAPER), g["path"])
    s["time"]["duration"] = duration
    if normalization:
        s.setdefault("model", {})["normalization"] = normalization
    out = os.path.join(work, f"{name}.{variant}")
    s["output"]["directory"] = out
    s["output"]["formats"] = ["vtu"]
    s["output"]["checkpoint_every"] = 0
    copy = os.path.join(work, f"{name}.{variant}.json")
    json.dump(s, open(copy, "w"), indent=1)
    return copy, out, s["time"]["frame_rate"]


def run_stats(run):
    summary = json.load(open(os.path.join(run, "summary.json")))
    onset = None
    files = frames(run)
    for f in files:
        broken = read_vtu(f, ("broken_bonds",))["broken_bonds"]
        if any(broken):
            onset = f
            break
    onset_time = None
    if onset is not None:
        series = open(os.path.join(run, "particles.pvd")).read()
        base = os.path.basename(onset)
        for line in series.splitlines():
            if base in line:
                onset_time = float(line.split('timestep="')[1].split('"')[0])
    last = read_vtu(files[-1], ("fragment_id", "mass"))
    pieces = {}
    for fid, m in zip(last["fragment_id"], last["mass"]):
        pieces[fid] = pieces.get(fid, 0.0) + m
    total = sum(pieces.values())
    return {"fragments": summary["fragments"], "largest_piece": max(pieces.values()) / total if total else 0.0,
            "pieces_1pct": sum(1 for m in pieces.values() if total and m >= 0.01 * total),
            "onset_frame_s": onset_time, "first_break_s": summary.get("first_break_time", "absent"),
            "onset_s": onset_time, "particles": summary["particles"], "step_wall_s": summary["step_wall_seconds"]}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--perifx", default="build/perifx")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--normalization", default="")
    ap.add_argument("--work", default="out/preview_vs_final")
    ap.add_argument("--reuse", action="store_true")
    ap.add_argument("pairs", nargs="+")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    print("| scene | model | common time (s) | particles preview / full | motion deviation mean / max (% of diagonal) "
          "| fracture onset preview / full (s) | fragments preview / full | pieces ≥ 1 % of the mass preview / full "
          "| largest piece preview / full |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in a.pairs:
        dur = min(json.load(open(os.path.join(PAPER, f"{name}.{v}.json")))["time"]["duration"] for v in ("preview", "full"))
        runs = {}
        for v in ("preview", "full"):
            copy, out, rate = scene_copy(name, v, dur, a.normalization, a.work)
            if a.reuse and os.path.exists(os.path.join(out, "summary.json")):
                runs[v] = out
                continue
            r = subprocess.run([a.perifx, "run", copy, "--threads", str(a.threads), "--quiet", "--overwrite"],
                               capture_output=True, text=True)
            limit = re.search(r"expected at most the stable step ([0-9.e+-]+) s", r.stderr)
            if r.returncode == 4 and limit:
                # A stiffer model than the scene was made for (--normalization): the largest time step
                # at 90 % of the limit that still puts every frame on a step.
                steps_per_frame = math.ceil(1.0 / (rate * 0.9 * float(limit.group(1))))
                s = json.load(open(copy))
                s["time"]["dt"] = 1.0 / (rate * steps_per_frame)
                json.dump(s, open(copy, "w"), indent=1)
                print(f"{copy}: time step lowered to {s['time']['dt']:.4g} s (stable limit {limit.group(1)} s)",
                      file=sys.stderr)
                r = subprocess.run([a.perifx, "run", copy, "--threads", str(a.threads), "--quiet", "--overwrite"],
                                   capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"{copy}: perifx run exited {r.returncode}: {(r.stderr or r.stdout)[-400:]}")
            runs[v] = out
        r = subprocess.run([a.perifx, "compare", runs["full"], runs["preview"]], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"{name}: perifx compare exited {r.returncode}: {(r.stderr or r.stdout)[-400:]}")
        rows = list(csv.reader(open(os.path.join(runs["full"], "compare.csv"))))
        overall = [row for row in rows if row and row[0] == "overall"][0]
        dev_max, dev_mean = float(overall[2]), float(overall[3])
        p, f = run_stats(runs["preview"]), run_stats(runs["full"])
        if p["first_break_s"] != "absent" and f["first_break_s"] != "absent":  # step resolution for both
            p["onset_s"], f["onset_s"] = p["first_break_s"], f["first_break_s"]
        model = a.normalization or json.load(open(os.path.join(PAPER, f"{name}.full.json"))).get("model", {}).get(
            "normalization", "corrected")
        if not a.normalization:
            pm = json.load(open(os.path.join(PAPER, f"{name}.preview.json"))).get("model", {}).get("normalization")
            if pm and pm != model:
                model = f"{pm} / {model}"

        def onset(x):
            return "—" if x["onset_s"] is None else f"{x['onset_s']:.4g}"
        print(f"| {name} | {model} | {dur:g} | {p['particles']} / {f['particles']} | {100 * dev_mean:.2f} / "
              f"{100 * dev_max:.2f} | {onset(p)} / {onset(f)} | {p['fragments']} / {f['fragments']} | "
              f"{p['pieces_1pct']} / {f['pieces_1pct']} | {p['largest_piece']:.3f} / {f['largest_piece']:.3f} |", flush=True)
        print("PREVIEW_VS_FINAL " + json.dumps({"scene": name, "model": model, "duration": dur, "deviation_mean": dev_mean,
                                                "deviation_max": dev_max, "preview": p, "full": f}), file=sys.stderr,
              flush=True)


if __name__ == "__main__":
    main()
