#!/usr/bin/env python3
"""Measures particles, bonds and seconds per step of paper scenes (for assets/report/table1.md).

    python3 assets/scenes/paper/measure.py [--perifx build/perifx] [--steps 20] [--threads 2] SCENE.json...

For each scene it runs `perifx info SCENE --threads N` (particles, bonds) and then
`perifx run TMP --frames 1 --quiet --threads N --out TMPDIR` on a temporary copy of the scene whose
duration and frame rate are set so that one frame is exactly --steps steps (mesh paths made
absolute). s/step is summary.json's step_wall_seconds / steps (set-up and output excluded); the
CPU time of the child (user + sys, which includes set-up) is reported too, because a loaded machine
inflates wall-clock time: cpu_s_per_step = (CPU of the run - CPU of `info`, i.e. the set-up) / steps;
on an idle machine with 2 threads, s/step is about cpu_s_per_step / 2. est_idle_s_per_step is a
second estimate: s_per_step x (CPU time / wall time of the whole run) / threads. Prints one JSON object per scene.
"""
import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--perifx", default="build/perifx")
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    for path in a.scenes:
        b0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        info = subprocess.run([a.perifx, "info", path, "--threads", str(a.threads)], capture_output=True, text=True)
        b1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        info_cpu = b1.ru_utime + b1.ru_stime - b0.ru_utime - b0.ru_stime
        m_p = re.search(r"^particles\s+(\d+)", info.stdout, re.M)
        m_b = re.search(r"^bonds\s+(\d+)", info.stdout, re.M)
        m_dt = re.search(r"stable limit ([0-9.e+-]+) s", info.stdout)
        s = json.load(open(path))
        folder = os.path.dirname(os.path.abspath(path))
        for b in s["bodies"]:
            g = b["geometry"]
            if "path" in g:
                g["path"] = os.path.join(folder, g["path"])
        dt = s["time"]["dt"]
        s["time"]["duration"] = a.steps * dt
        s["time"]["frame_rate"] = 1.0 / (a.steps * dt)
        with tempfile.TemporaryDirectory() as tmp:
            scene = os.path.join(tmp, "scene.json")
            json.dump(s, open(scene, "w"))
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.time()
            r = subprocess.run([a.perifx, "run", scene, "--frames", "1", "--quiet", "--threads", str(a.threads),
                                "--out", os.path.join(tmp, "out")], capture_output=True, text=True)
            wall = time.time() - t0
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            out = {"scene": path, "particles": int(m_p.group(1)) if m_p else None,
                   "bonds_directed": int(m_b.group(1)) if m_b else None,
                   "stable_dt": float(m_dt.group(1)) if m_dt else None, "dt": dt, "exit": r.returncode,
                   "total_wall_s": round(wall, 2),
                   "total_cpu_s": round(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, 2),
                   "max_rss_mb": round(after.ru_maxrss / 1024)}
            try:
                summ = json.load(open(os.path.join(tmp, "out", "summary.json")))
                out["steps"] = summ["steps"]
                out["s_per_step"] = summ["step_wall_seconds"] / summ["steps"]
                # CPU seconds per step: the run's CPU time minus the set-up CPU time that `info` needed.
                out["cpu_s_per_step"] = (out["total_cpu_s"] - info_cpu) / summ["steps"]
                # Second estimate, robust when set-up dominates: the share of the 2 cores the run got.
                share = out["total_cpu_s"] / max(wall, 1e-9)
                out["est_idle_s_per_step"] = out["s_per_step"] * share / a.threads
            except (OSError, KeyError, ValueError):
                out["error"] = (r.stderr or r.stdout)[-300:]
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    sys.exit(main())
