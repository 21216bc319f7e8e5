#!/usr/bin/env python3
"""Runs paper preview scenes to the end and reports their wall time (for assets/report/table1.md).

    python3 assets/report/time_previews.py [--perifx build/perifx] [--threads 2] SCENE.json...

Each scene runs as `perifx run SCENE --quiet --threads N --out TMPDIR` (all frames, all output, as a
user would run it). Prints one markdown table row per scene: particles, directed bonds, steps, wall
time of the whole command (set-up, stepping and output), step time and output time from
summary.json, alive bonds and fragments at the end.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--perifx", default="build/perifx")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    print("| preview scene | particles | bonds | steps | wall (s) | stepping (s) | output (s) | alive bonds | fragments |")
    print("|---|---|---|---|---|---|---|---|---|")
    for path in a.scenes:
        with tempfile.TemporaryDirectory() as tmp:
            out = os.path.join(tmp, "out")
            t0 = time.time()
            r = subprocess.run([a.perifx, "run", path, "--quiet", "--threads", str(a.threads), "--out", out],
                               capture_output=True, text=True)
            wall = time.time() - t0
            if r.returncode != 0:
                print(f"| `{os.path.basename(path)}` | failed (exit {r.returncode}): {r.stderr.strip()[:200]} |")
                continue
            s = json.load(open(os.path.join(out, "summary.json")))
            print(f"| `{os.path.basename(path)}` | {s['particles']} | {s['bonds']} | {s['steps']} | {wall:.1f} | "
                  f"{s['step_wall_seconds']:.1f} | {s['output_wall_seconds']:.1f} | {s['alive_bonds']} | {s['fragments']} |")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
