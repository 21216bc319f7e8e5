#!/usr/bin/env bash
# Gated consumer tests of perifx's exports (ctest labels `consumer`): each runs the small
# tests/engine/data/export_pane.json scene, then the program that reads the files:
#   run.sh blender         PERIFX BUILD_DIR SOURCE_DIR   Blender: Mesh Cache on animation.obj/.pc2, glb import
#   run.sh paraview        PERIFX BUILD_DIR SOURCE_DIR   pvpython: which attributes survive (README table)
#   run.sh gltf_validator  PERIFX BUILD_DIR SOURCE_DIR   Khronos glTF Validator: 0 errors, 0 warnings
#   run.sh gltf_previews   PERIFX BUILD_DIR SOURCE_DIR   the same on every fracture preview (first 2 frames;
#                                                         fig05 and fig14 only with PERIFX_LONG_TESTS=1)
# A missing program is not a failure: the test prints "SKIPPED: <why>" and exits 77 (ctest: Skipped).
set -euo pipefail
tool=$1 perifx=$2 build=$3 src=$4
here="$src/tests/engine/io/consumers"
out="$build/consumer_tests/$tool"
validator="${GLTF_VALIDATOR:-$build/gltf_validator/node_modules/gltf-validator}"
skip() { echo "SKIPPED: $*"; exit 77; }

case "$tool" in
  blender) command -v blender >/dev/null || skip "blender is not installed (Debian: apt-get install blender)" ;;
  paraview) command -v pvpython >/dev/null || skip "pvpython is not installed (Debian: apt-get install paraview python3-paraview)" ;;
  gltf_validator | gltf_previews)
    command -v node >/dev/null || skip "node is not installed (Debian: apt-get install nodejs npm)"
    [[ -f "$validator/package.json" ]] || skip "gltf-validator is not installed in $validator (.ci/run installs it: npm install --prefix $build/gltf_validator gltf-validator)" ;;
  *) echo "unknown consumer '$tool'"; exit 2 ;;
esac

mkdir -p "$out"
if [[ "$tool" == gltf_previews ]]; then
  # Each fracture preview, 2 frames, with output.formats = ["gltf"] (a copy of the scene with its mesh
  # paths made absolute).
  files=()
  for scene in "$src"/assets/scenes/paper/*.preview.json; do
    grep -q critical_stretch "$scene" || continue
    name=$(basename "$scene" .preview.json)
    # Slow even for 2 frames (as kSlowPreviews in tests/engine/test_paper_scenes.cpp): long tests only.
    if [[ "$name" == fig05_ductile_fracture || "$name" == fig14_creature_tear ]] && [[ "${PERIFX_LONG_TESTS:-}" != 1 ]]; then
      echo "$name: slow, validated only with PERIFX_LONG_TESTS=1"
      continue
    fi
    python3 - "$scene" "$out/$name.json" <<'PY'
import json, os, sys
src, dst = sys.argv[1], sys.argv[2]
s = json.load(open(src))
for b in s.get("bodies", []):
    g = b.get("geometry", {})
    if "path" in g and not os.path.isabs(g["path"]):
        g["path"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(src)), g["path"]))
s.setdefault("output", {})["formats"] = ["gltf"]
json.dump(s, open(dst, "w"), indent=1)
PY
    "$perifx" run "$out/$name.json" --out "$out/$name" --frames 2 --overwrite --quiet
    files+=("$out/$name/animation.glb")
  done
  GLTF_VALIDATOR="$validator" node "$here/validate_gltf.js" "${files[@]}"
  exit
fi

"$perifx" run "$src/tests/engine/data/export_pane.json" --out "$out/run" --overwrite --quiet
case "$tool" in
  blender) blender -b --factory-startup --python-exit-code 1 --python "$here/blender_check.py" -- "$out/run" 2>&1 |
             grep -v '^Progress:\|^$\|^Blender quit\|^Read prefs\|^Read blend' ; exit "${PIPESTATUS[0]}" ;;
  paraview) pvpython "$here/paraview_check.py" "$out/run" ;;
  gltf_validator) GLTF_VALIDATOR="$validator" node "$here/validate_gltf.js" "$out/run/animation.glb" ;;
esac
