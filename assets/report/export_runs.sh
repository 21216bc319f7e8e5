#!/usr/bin/env bash
# Makes the runs behind assets/report/export.md (from the repository root, after a Release build and
# `npm install --prefix build/gltf_validator gltf-validator`):
#   bash assets/report/export_runs.sh OUT_DIR
# Every fracture preview is run for its first FRAMES frames (2 for the slow fig05/fig14, as in the
# tests) with output.formats = ["surface_ply", "cache", "gltf"] and two threads, its animation.glb
# validated; fig01_brittle_walls and fig16_bunny_drop are run for the frames rendered in the report.
set -euo pipefail
out=${1:?usage: export_runs.sh OUT_DIR}
mkdir -p "$out"
frames_of() {
  case "$1" in
    fig01_brittle_walls) echo 20 ;;   # as assets/report/gallery.md
    fig16_bunny_drop) echo 12 ;;
    fig05_ductile_fracture | fig14_creature_tear) echo 2 ;;
    *) echo 4 ;;
  esac
}
glbs=()
for scene in assets/scenes/paper/*.preview.json; do
  grep -q critical_stretch "$scene" || continue
  name=$(basename "$scene" .preview.json)
  python3 - "$scene" "$out/$name.json" <<'PY'
import json, os, sys
src, dst = sys.argv[1], sys.argv[2]
s = json.load(open(src))
for b in s.get("bodies", []):
    g = b.get("geometry", {})
    if "path" in g and not os.path.isabs(g["path"]):
        g["path"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(src)), g["path"]))
s.setdefault("output", {})["formats"] = ["surface_ply", "cache", "gltf"]
json.dump(s, open(dst, "w"), indent=1)
PY
  start=$(date +%s)
  ./build/perifx run "$out/$name.json" --out "$out/$name" --frames "$(frames_of "$name")" --threads 2 --overwrite --quiet
  echo "$name: $(frames_of "$name") frames in $(( $(date +%s) - start )) s"
  glbs+=("$out/$name/animation.glb")
done
GLTF_VALIDATOR=build/gltf_validator/node_modules/gltf-validator node tests/engine/io/consumers/validate_gltf.js "${glbs[@]}" | tee "$out/validator.txt"
