#!/usr/bin/env bash
# Drives icube-view as a person would, under Xvfb: builds the demo town
# (icube world demo-scene + world build), runs viewer/sessions/two_passes.script
# (keys, autopilot, two recorded passes, screenshots, save), then checks the
# saved trajectory with icube-view --verify (2 passes x 93 frames, forward
# progress, camera 2 m above the ground) and that both PNGs exist. The
# semantic screenshot's class histogram is compared with the headless buffer
# inside the session (it fails the run when they differ).
#
#   viewer/check_session.sh [BUILD_DIR]      (default build/; output in BUILD_DIR/viewer-check)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
out="$build/viewer-check"
icube="${ICUBE_BIN:-$build/icube}"  # the CLI that builds the demo town
rm -rf "$out"
mkdir -p "$out"
"$icube" world demo-scene -o "$out/scene.json" >/dev/null
"$icube" world build "$out/scene.json" -o "$out/world.icw" >/dev/null
sed "s|@SEMANTIC@|$out/semantic.png|" viewer/sessions/two_passes.script > "$out/session.script"
timeout 600 xvfb-run -a -s "-screen 0 1280x720x24" "$build/icube-view" "$out/world.icw" --scene "$out/scene.json" \
  --script "$out/session.script" --record-out "$out/passes.npy" --screenshot-out "$out/shaded.png" \
  --size 640 --scale 0.5 --stats --no-vsync
"$build/icube-view" "$out/world.icw" --verify "$out/passes.npy" --expect-passes 2
"$build/icube-view" "$out/world.icw" --verify "$out/passes_pass1.json" --expect-passes 1
for f in shaded.png semantic.png passes.npy passes_pass0.json passes_pass1.json; do
  [ -s "$out/$f" ] || { echo "check_session: missing $out/$f" >&2; exit 1; }
done
echo "check_session: ok ($out)"
