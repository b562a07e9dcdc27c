#!/usr/bin/env bash
# Drives icube-view on a package's Gaussians under Xvfb: makes a small package
# of the demo town (icube generate, 20 frames, no videos), runs
# viewer/sessions/gaussians.script (autopilot in the Gaussian view with the
# cars playing and adaptive resolution, one recorded pass of 12 frames,
# screenshots of the Gaussians and of the semantic voxel view, a jump in
# time, save, load, gaussian-shots), then checks
#  - the saved pass with icube-view --verify (1 pass x 12 frames, forward
#    progress, camera height above the world's ground) and that the PNGs exist;
#  - the semantic voxel screenshot against the headless buffer (in the session);
#  - replay through the splatting CLI: `icube splat render gaussians/scene.json
#    --trajectory passes_pass0.json --sky gaussians/sky.png` renders the pass,
#    and icube-view --compare-rgb requires each of the viewer's gaussian-shots
#    (every STEP-th frame: the whole static set assembled on the GPU from its
#    chunks, the cars placed at the frame) to equal the CLI's frame within 2
#    levels on all but 0.1 % of the pixels.
#
#   viewer/check_gaussian_session.sh [BUILD_DIR] [STEP]   (default build/ 4; output in BUILD_DIR/viewer-gaussian-check)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
step="${2:-4}"
out="$build/viewer-gaussian-check"
icube="${ICUBE_BIN:-$build/icube}"
rm -rf "$out"
mkdir -p "$out"
"$icube" world demo-scene -o "$out/scene.json" >/dev/null
"$icube" generate "$out/scene.json" --frames 0:40:2 --no-video -o "$out/package" >"$out/generate.log" 2>&1 ||
  { cat "$out/generate.log"; exit 1; }
pkg="$out/package"
sed -e "s|@OUT@|$out|g" -e "s|@STEP@|$step|g" viewer/sessions/gaussians.script > "$out/session.script"
timeout 600 xvfb-run -a -s "-screen 0 1280x720x24" "$build/icube-view" "$pkg" --script "$out/session.script" \
  --record-out "$out/passes.npy" --frames-per-pass 12 --size 640 --stats --no-vsync
"$build/icube-view" "$pkg" --verify "$out/passes.npy" --expect-passes 1 --frames-per-pass 12
for f in gaussians.png voxels_semantic.png gaussians_t20.png passes.npy passes_pass0.json gshot_p0_f000.png; do
  [ -s "$out/$f" ] || { echo "check_gaussian_session: missing $out/$f" >&2; exit 1; }
done
"$icube" splat render "$pkg/gaussians/scene.json" --trajectory "$out/passes_pass0.json" --sky "$pkg/gaussians/sky.png" \
  -o "$out/splat" >/dev/null 2>&1
compared=0
for shot in "$out"/gshot_p0_f*.png; do
  f=$((10#$(basename "$shot" .png | sed 's/.*_f//')))
  ref=$(printf '%s/splat/%06d.png' "$out" "$f")
  [ -s "$ref" ] || { echo "check_gaussian_session: icube splat render wrote no $ref" >&2; exit 1; }
  "$build/icube-view" --compare-rgb "$shot" "$ref" --max-level-diff 2 --max-mismatch 0.001 >/dev/null ||
    { "$build/icube-view" --compare-rgb "$shot" "$ref" --max-level-diff 2 --max-mismatch 0.001; exit 1; }
  compared=$((compared + 1))
done
frames=$(( (12 + step - 1) / step ))
[ "$compared" -eq "$frames" ] || { echo "check_gaussian_session: compared $compared frames, expected $frames" >&2; exit 1; }
echo "check_gaussian_session: ok ($out; $compared Gaussian frames equal to icube splat render)"
