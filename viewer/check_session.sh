#!/usr/bin/env bash
# Drives icube-view as a person would, under Xvfb: builds the demo town
# (icube world demo-scene + world build), runs viewer/sessions/two_passes.script
# (keys, autopilot, two recorded passes, screenshots, save, load + replay,
# teleports), then checks
#  - the saved trajectory with icube-view --verify (2 passes x 93 frames,
#    forward progress, camera 2 m above the ground) and that the PNGs exist;
#  - replay through Stage 2: `icube buffers --trajectory passes.npy` renders
#    every STEP-th frame of both passes (STEP=10 by default: frames 0, 10, ..,
#    90 of each, 20 frames; STEP=1 compares all 2 x 93 previewed frames but
#    adds ~5 min on lavapipe: each target-camera frame-shot costs ~1.2 s in
#    the session and icube buffers ~0.4 s more per frame) and icube-view
#    --compare-semantic requires the viewer's frame-shot of each of them to
#    equal its semantic_buffer PNG (instance-coloured cars aside) on all but
#    0.1 % of the pixels.
# The class histograms of the semantic and shaded screenshots (the latter with
# shadows + AO too) are compared with the headless buffer inside the session
# (it fails the run when they differ).
#
#   viewer/check_session.sh [BUILD_DIR] [STEP]   (default build/ 10; output in BUILD_DIR/viewer-check)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
step="${2:-10}"
out="$build/viewer-check"
icube="${ICUBE_BIN:-$build/icube}"  # the CLI that builds the demo town and renders Stage 2 buffers
rm -rf "$out"
mkdir -p "$out"
"$icube" world demo-scene -o "$out/scene.json" >/dev/null
"$icube" world build "$out/scene.json" -o "$out/world.icw" >/dev/null
sed -e "s|@OUT@|$out|g" -e "s|@STEP@|$step|g" viewer/sessions/two_passes.script > "$out/session.script"
timeout 600 xvfb-run -a -s "-screen 0 1280x720x24" "$build/icube-view" "$out/world.icw" --scene "$out/scene.json" \
  --script "$out/session.script" --record-out "$out/passes.npy" --screenshot-out "$out/shaded.png" \
  --size 640 --scale 0.5 --stats --no-vsync
"$build/icube-view" "$out/world.icw" --verify "$out/passes.npy" --expect-passes 2
"$build/icube-view" "$out/world.icw" --verify "$out/passes_pass1.json" --expect-passes 1
for f in shaded.png semantic.png shaded_shadows.png passes.npy passes_pass0.json passes_pass1.json frame_p0_f000.png \
         frame_p1_f000.png; do
  [ -s "$out/$f" ] || { echo "check_session: missing $out/$f" >&2; exit 1; }
done
"$icube" buffers "$out/world.icw" --scene "$out/scene.json" --trajectory "$out/passes.npy" --frames "::$step" --no-video \
  --clip replay -o "$out/buffers" >/dev/null 2>&1
compared=0
for shot in "$out"/frame_p*_f*.png; do
  name=$(basename "$shot" .png)  # frame_p<P>_f<FFF>
  p=${name#frame_p}
  p=${p%%_*}
  f=$((10#${name##*_f}))
  # Buffers number their frames 0..N-1; buffers_meta.json maps each to its source frame.
  meta="$out/buffers/replay/pass_$p/buffers_meta.json"
  sources=$(sed -n 's/.*"source_frame_indices": *\[\([^]]*\)\].*/\1/p' "$meta" 2>/dev/null | tr -d ' ')
  i=0; n=-1
  for s in ${sources//,/ }; do [ "$s" -eq "$f" ] && n=$i; i=$((i + 1)); done
  [ "$n" -ge 0 ] || { echo "check_session: $meta lists no source frame $f" >&2; exit 1; }
  ref=$(printf '%s/buffers/replay/pass_%s/semantic_buffer/%06d.png' "$out" "$p" "$n")
  [ -s "$ref" ] || { echo "check_session: icube buffers wrote no $ref (source frame $f)" >&2; exit 1; }
  "$build/icube-view" --compare-semantic "$shot" "$ref" >/dev/null ||
    { "$build/icube-view" --compare-semantic "$shot" "$ref"; exit 1; }
  compared=$((compared + 1))
done
frames=$(( (93 + step - 1) / step * 2 ))
[ "$compared" -eq "$frames" ] || { echo "check_session: compared $compared frames, expected $frames" >&2; exit 1; }
echo "check_session: ok ($out; $compared replayed frames equal to icube buffers)"
