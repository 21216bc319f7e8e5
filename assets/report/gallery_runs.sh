#!/usr/bin/env bash
# Makes the stills of assets/report/gallery.md and the every-frame surface check of
# assets/report/surfaces.md (from the repository root, after a Release build):
#   bash assets/report/gallery_runs.sh OUT_DIR [FIGURE...]
# Each figure's preview scene runs on one thread (two figures at a time): to the rendered frame, or,
# for the scenes that break (marked "all"), to its end, after which `perifx check-surface` checks every
# frame's surface (OUT_DIR/check/FIGURE.txt). The frame is rendered from the embedded-mesh surface
# (crack faces orange) with the built-in rasterizer at 1280×720 and copied to
# assets/report/images/FIGURE.png. Only Fig. 6, a damage plot in the paper too, draws the particles
# coloured by damage. Wall times go to OUT_DIR/times.txt. FIGURE may also be "showcase" (the fracture
# showcase scene: run and checked, not rendered). PERIFX=path picks the binary (default ./build/perifx);
# every run has --profile, so OUT_DIR/FIGURE/summary.json holds the wall time per system.
set -euo pipefail
perifx=${PERIFX:-./build/perifx}
out=${1:?usage: gallery_runs.sh OUT_DIR [FIGURE...]}
shift
mkdir -p "$out"
# figure | frame | run (frame: up to the rendered frame; all: every frame, then check-surface) | render options
table='
fig01_brittle_walls|20|all|--view 0.25,0.3,1 --fit-frames 0
fig01_ductile_walls|10|all|--view 0.25,0.3,1 --fit-frames 0
fig03_creature_release|10|frame|--zoom 1.2
fig04_elastic_wall|2|frame|--view 0.8,0.3,1 --zoom 1.2
fig04_plastic_wall|6|frame|--view 0.8,0.3,1 --zoom 1.2
fig05_ductile_fracture|5|all|--view 0.25,0.3,1 --fit-frames 0
fig06_crack_patterns|20|all|--draw particles --color-by damage --view 0,0.2,1 --fit-frames 0
fig07_glass_alpha|20|all|--view 0,0.25,1 --fit-frames 0
fig08_jello_bullet|8|frame|--cut 0,0,1,0.01 --view 0.35,0.3,1 --fit-frames 0 --zoom 1.2
fig09_beam_stretch|10|frame|--view 0.15,1,0.35
fig10_soft_beam|8|frame|--view 0.3,0.2,1
fig10_stiff_beam|4|frame|--view 0.3,0.2,1
fig11_bar_swing|6|frame|--view 0.3,0.2,1
fig12_bar_twist|15|frame|
fig13_creature_vibration|29|frame|--zoom 1.2
fig14_creature_tear|7|all|--fit-frames 0:6
fig15_glass_ball_press|20|all|--view 0.25,1,0.45 --cut 0,1,0,0.15 --zoom 1.3
fig16_bunny_drop|12|all|--fit-frames 0:5
fig17_thin_sheet|3|all|--view 0.3,0.25,1 --fit-frames 0:6
showcase|0|all|
'
one() {
  local name=$1 frame=$2 run=$3 options=$4
  local scene=assets/scenes/paper/$name.preview.json start
  if [ "$name" = showcase ]; then
    # The showcase writes VTU only; the checker needs the particle PLY and the surface PLY.
    scene=$out/showcase.json
    /usr/bin/python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); s.setdefault("output",{})["formats"]=["vtu","ply","surface_ply"]; json.dump(s,open(sys.argv[2],"w"),indent=1)' \
      assets/scenes/showcase.json "$scene"
  fi
  local frames=(--frames "$frame")
  [ "$run" = all ] && frames=()
  start=$(date +%s)
  "$perifx" run "$scene" --out "$out/$name" "${frames[@]}" --threads 1 --overwrite --quiet --profile
  local ran=$(( $(date +%s) - start ))
  if [ "$run" = all ]; then
    mkdir -p "$out/check"
    "$perifx" check-surface "$out/$name" > "$out/check/$name.txt" 2>&1 || echo "check-surface exit $?" >> "$out/check/$name.txt"
  fi
  [ "$name" = showcase ] && { echo "$name: run $ran s" >> "$out/times.txt"; return; }
  # shellcheck disable=SC2086  # options are words
  "$perifx" render "$out/$name" --scene "$scene" --backend builtin --threads 1 --width 1280 --height 720 \
    --frames "$frame:$frame" --quiet $options
  cp "$out/$name/render/frame.$(printf %04d "$frame").png" "assets/report/images/$name.png"
  echo "$name: frame $frame, run $ran s" >> "$out/times.txt"
}
jobs_running=0
while IFS='|' read -r name frame run options; do
  [ -n "$name" ] || continue
  if [ $# -gt 0 ] && ! printf '%s\n' "$@" | grep -qx "$name"; then continue; fi
  one "$name" "$frame" "$run" "$options" &
  jobs_running=$((jobs_running + 1))
  if [ "$jobs_running" -ge 2 ]; then wait -n; jobs_running=$((jobs_running - 1)); fi
done <<< "$table"
wait
sort "$out/times.txt"
