#!/usr/bin/env bash
# Distributed runs are bit-identical to one process (issue 17): runs mpi_impact.json (plasticity,
# fracture with damage-dependent limits, particle contact with friction, a steel ball, an anchor, a
# velocity condition, gravity, a surface traction, and an anisotropic block the plate's pieces strike,
# so isotropic and anisotropic rows of the bond kernels meet) in one process, then under mpirun at 1,
# 2, 3 and 4 ranks of 1 thread, at 2 ranks of 2 threads and at 3 ranks over TCP (loopback), and
# compares every output file byte for byte: particle frames (vtu, ply), split-mesh surfaces (obj,
# ply, vtp), tet meshes (vtu), the Blender cache (animation.obj/.pc2), glTF, dust, pieces.csv,
# mesh.json and projectiles.csv (all but summary.json and checkpoint.bin). It first checks that the
# reference run yields, breaks into pieces, is struck by the ball and lifted by a rising box collider
# (which reads the surface frames computed from ghosts), so the comparison covers all four. A run of 3 ranks
# re-splits its work every 20 steps (rebalance_drift 0). Then a run of 2 ranks stopped at frame 7 is
# resumed from its checkpoint by 3 ranks, and by one process: the same bytes. Last, the same comparison
# for the FEM solver (mpi_fem.json) at 2 and 3 ranks and 2 ranks x 2 threads, and the memory
# preflight of 4 ranks sharing this machine (a scene that fits one process is refused). --bind-to none: Open MPI
# otherwise pins each rank to one core, and oneTBB would then run 2 threads on it as 1.
#   usage: mpi_identity.sh PERIFX MPIRUN WORKDIR
set -euo pipefail
perifx=$1 mpirun=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
scene=$here/mpi_impact.json
rm -rf "$work"
mkdir -p "$work"

"$perifx" run "$scene" --threads 1 --quiet --out "$work/one_process"

# The reference must exercise plasticity and fracture: some bond broken, some plastic strain.
python3 - "$work/one_process" <<'EOF'
import json, struct, sys, pathlib
run = pathlib.Path(sys.argv[1])
summary = json.loads((run / "summary.json").read_text())
broken = summary["bonds"] - summary["alive_bonds"]
# plastic_strain of the last frame, from the VTU's appended raw data (UInt64 byte count, then Float64s).
last = sorted(run.glob("particles.*.vtu"))[-1].read_bytes()
head, data = last.split(b'<AppendedData encoding="raw">', 1)
data = data[data.index(b"_") + 1:]
tag = head[head.index(b'Name="plastic_strain"'):]
offset = int(tag[tag.index(b'offset="') + 8:].split(b'"')[0])
size = struct.unpack_from("<Q", data, offset)[0]
plastic = max(struct.unpack_from("<%dd" % (size // 8), data, offset + 8))
# The ball's largest contact force over the frames (projectiles.csv: fx, fy, fz).
rows = (run / "projectiles.csv").read_text().splitlines()[1:]
ball = max(sum(float(v) ** 2 for v in row.split(",")[11:14]) ** 0.5 for row in rows)
# The rising box collider (top at y = -0.102 + 1 m/s * t over x in [0.05, 0.15], z in [-0.05, 0.05]) has
# lifted the plate's bottom edge: the lowest particle over it ends above where the edge began (-0.1 m).
ply = sorted(run.glob("particles.*.ply"))[-1].read_bytes()
header, body = ply.split(b"end_header\n", 1)
props = [line.split() for line in header.splitlines() if line.startswith(b"property")]
kinds = {b"float": "f", b"double": "d", b"uint": "I", b"int": "i", b"uchar": "B", b"ushort": "H"}
fmt = "<" + "".join(kinds[p[1]] for p in props)
count = int(header.split(b"element vertex ")[1].split()[0])
names = [p[2] for p in props]
ix, iy = names.index(b"x"), names.index(b"y")
rows_ply = [struct.unpack_from(fmt, body, k * struct.calcsize(fmt)) for k in range(count)]
iz = names.index(b"z")
lifted = min(r[iy] for r in rows_ply if 0.06 < r[ix] < 0.14 and abs(r[iz]) < 0.04)
print(f"mpi_identity: one process: {summary['particles']} particles, {broken} of {summary['bonds']} bonds broken, "
      f"first break at {summary['first_break_time']} s, largest plastic strain {plastic:.3g}, "
      f"largest ball force {ball:.3g} N, {summary['fragments']} pieces, lowest particle over the box collider "
      f"at y = {lifted:.4f} m")
if broken == 0 or not plastic > 0 or not ball > 0 or summary["fragments"] < 2 or not lifted > -0.09:
    sys.exit("mpi_identity: the reference run must break into pieces, yield, be struck and be lifted by the box "
             "collider; the scene no longer tests that")
EOF

fail=0
# compare LABEL DIR [REFERENCE]: every frame file of the one-process run (or REFERENCE) against DIR's,
# byte for byte.
compare() {
  local count=0 f name
  for f in "${3:-$work/one_process}"/*; do
    name=$(basename "$f")
    # summary.json holds timings and the rank count; checkpoint.bin notes that a run was distributed.
    [[ $name == summary.json || $name == checkpoint.bin ]] && continue
    if ! cmp -s "$f" "$2/$name"; then
      echo "mpi_identity: $1: $name differs from one process"
      fail=1
    fi
    count=$((count + 1))
  done
  echo "mpi_identity: $1: $count files compared"
}

for spec in 1x1 2x1 3x1 4x1 2x2; do
  ranks=${spec%x*} threads=${spec#*x}
  out=$work/ranks${ranks}_threads${threads}
  "$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np "$ranks" "$perifx" run "$scene" --threads "$threads" --quiet --out "$out"
  compare "$ranks ranks x $threads threads" "$out"
done
# Over a network transport: the same 3-rank run with Open MPI's TCP transport on the loopback interface
# (pml ob1, btl tcp + self: no shared-memory path between the ranks), as ranks on separate machines
# talk; message sizes, ordering and completion then go through the TCP stack.
out=$work/ranks3_tcp
"$mpirun" --allow-run-as-root --oversubscribe --bind-to none --mca pml ob1 --mca btl tcp,self \
  --mca btl_tcp_if_include lo -np 3 "$perifx" run "$scene" --threads 1 --quiet --out "$out"
compare "3 ranks x 1 thread over TCP (loopback)" "$out"
# summary.json's per-rank figures (World::rank_stats): the shares add up to the world, every rank of the
# struck plate has bond and contact ghosts, and each step moves at least the motion halo (6 doubles per
# bond ghost) into every rank.
python3 - "$work/ranks4_threads1/summary.json" <<'EOF' || fail=1
import json, sys
s = json.load(open(sys.argv[1]))
stats = s["rank_stats"]
problems = []
if len(stats) != 4: problems.append(f"{len(stats)} entries for 4 ranks")
if sum(r["owned_particles"] for r in stats) != s["particles"]: problems.append("owned particles do not add up")
for k, r in enumerate(stats):
    if not (r["bond_ghosts"] > 0 and r["contact_ghosts"] > 0): problems.append(f"rank {k} has no ghosts: {r}")
    if not r["halo_bytes_per_step"] >= 48 * r["bond_ghosts"]: problems.append(f"rank {k}: halo below the motion halo: {r}")
    # Every rank takes part in every gather, and each pieces search ends with a round in which
    # no rank lowers a label, so it takes at least one round per gather, the same count on every rank.
    if r["state_gathers"] != stats[0]["state_gathers"] or r["state_gathers"] < 1: problems.append(f"rank {k}: state gathers {r}")
    if r["piece_rounds"] != stats[0]["piece_rounds"] or r["piece_rounds"] < r["state_gathers"]: problems.append(f"rank {k}: piece rounds {r}")
if not s["contact_list_builds"] > 0: problems.append("no contact list built")
print("mpi_identity: 4 ranks: " + "; ".join(f"rank {k} owns {r['owned_particles']}, {r['bond_ghosts']} bond + "
      f"{r['contact_ghosts']} contact ghosts, {r['halo_bytes_per_step'] / 1e3:.1f} kB/step" for k, r in enumerate(stats)))
if problems: sys.exit("mpi_identity: rank_stats: " + ", ".join(problems))
EOF
# Re-balancing: 3 ranks re-split whenever the equal-work split of the current work (alive bonds,
# contact candidates) differs from theirs, checked every 20 steps.
python3 - "$scene" "$work/rebalance.json" <<'EOF'
import json, sys
scene = json.load(open(sys.argv[1]))
scene["distributed"] = {"rebalance_drift": 0, "rebalance_interval": 20}
json.dump(scene, open(sys.argv[2], "w"))
EOF
out=$work/rebalanced
"$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np 3 "$perifx" run "$work/rebalance.json" --threads 1 --quiet --out "$out"
rebalances=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['rebalances'])" "$out/summary.json")
if ((rebalances == 0)); then
  echo "mpi_identity: the re-balancing run never re-split"
  fail=1
fi
compare "3 ranks re-split $rebalances times" "$out"
# Each rank's totals run through every re-split: a state gather per frame written and per re-split,
# and the same count of contact-ghost refreshes on every rank (the decision is collective).
python3 - "$out" "$rebalances" <<'EOF' || fail=1
import json, pathlib, sys
run, rebalances = pathlib.Path(sys.argv[1]), int(sys.argv[2])
stats = json.loads((run / "summary.json").read_text())["rank_stats"]
frames = len(list(run.glob("particles.*.vtu")))
want = frames + rebalances
bad = [k for k, r in enumerate(stats) if r["state_gathers"] != want or r["contact_ghost_refreshes"] != stats[0]["contact_ghost_refreshes"]]
print(f"mpi_identity: re-split run: {frames} frames + {rebalances} re-splits = {want} state gathers on every rank: "
      + ("no" if bad else "yes") + f" ({[r['state_gathers'] for r in stats]}); refreshes {[r['contact_ghost_refreshes'] for r in stats]}")
if bad: sys.exit("mpi_identity: rank_stats of the re-split run do not carry over: ranks " + str(bad))
EOF
# Resume: 2 ranks stop at frame 7 (checkpoint), then 3 ranks, and one process, continue to the end.
for resumer in 3 1; do
  out=$work/resumed_by_$resumer
  "$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np 2 "$perifx" run "$scene" --threads 1 --quiet \
    --frames 7 --out "$out"
  if ((resumer > 1)); then
    "$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np "$resumer" "$perifx" run "$scene" --threads 1 \
      --quiet --resume --out "$out"
  else
    "$perifx" run "$scene" --threads 1 --quiet --resume --out "$out"
  fi
  first=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['first_frame'])" "$out/summary.json")
  if [[ $first != 7 ]]; then
    echo "mpi_identity: resumed by $resumer rank(s): expected to continue after frame 7, began after $first"
    fail=1
  fi
  compare "2 ranks to frame 7, resumed by $resumer rank(s)" "$out"
done
# The FEM reference solver (mpi_fem.json: corotated tets, an anchor, a velocity condition, gravity, a
# traction, a ball and a rising box collider; its time step "auto", picked at set-up): 2 and 3 ranks of
# 1 thread and 2 ranks of 2 threads.
fem_scene=$here/mpi_fem.json
"$perifx" run "$fem_scene" --threads 1 --quiet --out "$work/fem_one_process"
python3 - "$work/fem_one_process" <<'EOF' || fail=1
import json, pathlib, sys
run = pathlib.Path(sys.argv[1])
s = json.loads((run / "summary.json").read_text())
rows = (run / "projectiles.csv").read_text().splitlines()[1:]
ball = max(sum(float(v) ** 2 for v in row.split(",")[11:14]) ** 0.5 for row in rows)
steps = 1 / (500 * s['dt'])  # the automatic step divides the frame interval (500 frames/s)
print(f"mpi_identity: FEM one process: {s['particles']} vertices, {s['frames']} frames, dt {s['dt']:.4g} s "
      f"(auto, {steps:.0f} steps per frame), largest ball force {ball:.3g} N")
if not ball > 0: sys.exit("mpi_identity: the ball must strike the FEM beam; the scene no longer tests that")
if abs(steps - round(steps)) > 1e-9 * steps: sys.exit("mpi_identity: the automatic step does not divide the frame interval")
EOF
for spec in 2x1 3x1 2x2; do
  ranks=${spec%x*} threads=${spec#*x}
  out=$work/fem_ranks${ranks}_threads${threads}
  "$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np "$ranks" "$perifx" run "$fem_scene" --threads "$threads" --quiet --out "$out"
  compare "FEM, $ranks ranks x $threads threads" "$out" "$work/fem_one_process"
done
# The memory preflight counts the ranks sharing a machine (engine/setup/preflight.hpp): a glass cube
# whose one-process estimate is about 60 % of this machine's available memory is refused (exit 8) when
# 4 ranks share the machine, with an estimate of 3 times the one-process one (rank 0's whole world and
# its part, 3 parts of 2 W/4); it is refused at the primitives' cell count, before anything is meshed.
available=$(awk '/^MemAvailable:/ {print $2 * 1024}' /proc/meminfo)
resolution=$(python3 -c "print(max(10, round((0.6 * $available / (1.25 * 6 * 1375.0)) ** (1 / 3))))")
cat > "$work/memory_cube.json" <<EOF
{"name": "memory_cube", "time": {"dt": 1e-6, "duration": 1e-5, "frame_rate": 1e5},
 "materials": {"glass": {"density": 2500, "youngs_modulus": 6e10, "poisson_ratio": 0.22, "critical_stretch": 0.001}},
 "bodies": [{"name": "cube", "material": "glass", "geometry": {"type": "box", "size": [1, 1, 1], "resolution": $resolution}}],
 "contact": {"enabled": true}, "output": {"directory": "$work/memory_cube"}}
EOF
set +e
refusal=$("$mpirun" --allow-run-as-root --oversubscribe --bind-to none -np 4 "$perifx" run "$work/memory_cube.json" --frames 1 2>&1)
code=$?
set -e
python3 - "$code" "$refusal" <<'EOF' || fail=1
import re, sys
code, text = int(sys.argv[1]), sys.argv[2]
units = {"B": 1, "KiB": 2**10, "MiB": 2**20, "GiB": 2**30, "TiB": 2**40}
m = re.search(r"estimated peak of ([0-9.]+) (\w+) on this machine, for 4 of the job's 4 ranks \(one process: ([0-9.]+) (\w+)\)", text)
if code != 8 or not m:
    sys.exit(f"mpi_identity: 4 ranks on one machine: expected exit 8 and the machine's estimate, got exit {code}: {text[:400]}")
machine, one = float(m.group(1)) * units[m.group(2)], float(m.group(3)) * units[m.group(4)]
print(f"mpi_identity: memory preflight, 4 ranks on one machine: refused (exit 8), {machine / 2**30:.3g} GiB for the machine against {one / 2**30:.3g} GiB in one process")
if abs(machine / one - 3.0) > 0.03:  # both printed to 3 digits
    sys.exit(f"mpi_identity: expected the machine's estimate to be 3 times the one-process one, got {machine / one:.4g}")
EOF
if ((fail)); then exit 1; fi
echo "mpi_identity: every output file is byte-identical to one process"
