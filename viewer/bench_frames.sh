#!/usr/bin/env bash
# icube-view frame-time benchmark (bench/README.md "icube-view frame times"):
# the autopilot drives the demo town's ego track with the dash camera
# (viewer/sessions/bench_drive.script, 4 simulated seconds = 120 frames) under
# Xvfb without vsync, at each size with and without adaptive resolution
# (--target-ms, default 45), each RUNS times; prints the --stats lines of every
# run (frame times; p50 of each part of a frame and the render scale) and a
# table of the run with the median p50. Load (uptime) first.
# PACKAGE=DIR benchmarks the Gaussian view of an icube generate package instead
# (viewer/sessions/bench_gaussians.script: the same drive with the cars playing;
# extra icube-view options in VIEW_OPTS, e.g. "--moving-lod 8,80").
#
#   viewer/bench_frames.sh [BUILD_DIR] [RUNS] [SIZES]   (defaults: build 3 "960 1280"; LP_NUM_THREADS=2)
#   PACKAGE=build/demo/package viewer/bench_frames.sh build 3 960
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
runs="${2:-3}"
sizes="${3:-960 1280}"
out="$build/viewer-bench"
icube="${ICUBE_BIN:-$build/icube}"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
mkdir -p "$out"
[ -s "$out/world.icw" ] || {
  "$icube" world demo-scene -o "$out/scene.json" >/dev/null
  "$icube" world build "$out/scene.json" -o "$out/world.icw" >/dev/null
}
echo "load: $(uptime)"
printf '| size | adaptive | frames | mean ms | p50 | p90 | p95 | p99 | max | fps (p50) |\n|---|---|---|---|---|---|---|---|---|---|\n' > "$out/table.md"
for w in $sizes; do
  for mode in fixed adaptive; do
    flag=""
    [ "$mode" = adaptive ] && flag="--adaptive --target-ms ${TARGET_MS:-45}"
    lines=()
    for ((r = 0; r < runs; ++r)); do
      if [ -n "${PACKAGE:-}" ]; then
        # shellcheck disable=SC2086
        full=$(timeout 300 xvfb-run -a -s "-screen 0 1920x1080x24" "$build/icube-view" "$PACKAGE" \
          --script viewer/sessions/bench_gaussians.script --size "$w" --no-vsync --stats $flag ${VIEW_OPTS:-})
      else
        full=$(timeout 300 xvfb-run -a -s "-screen 0 1920x1080x24" "$build/icube-view" "$out/world.icw" \
          --scene "$out/scene.json" --script viewer/sessions/bench_drive.script --size "$w" --no-vsync --stats $flag)
      fi
      line=$(echo "$full" | grep "stats")
      echo "$line"
      echo "$full" | grep "frame parts" || true
      lines+=("$line")
    done
    # The run with the median p50.
    best=$(printf '%s\n' "${lines[@]}" | awk '{for (i = 1; i <= NF; ++i) if ($i == "p50") print $(i + 1), NR}' | sort -n |
      awk -v n="${#lines[@]}" 'NR == int((n + 1) / 2) {print $2}')
    sel="${lines[$((best - 1))]}"
    get() { echo "$sel" | awk -v k="$1" '{for (i = 1; i <= NF; ++i) if ($i == k) print $(i + 1)}'; }
    h=$((w * 9 / 16))
    printf '| %sx%s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$w" "$h" "$mode" "$(get frames)" "$(get mean)" \
      "$(get p50)" "$(get p90)" "$(get p95)" "$(get p99)" "$(get max)" \
      "$(echo "$sel" | sed -n 's/.*(\([0-9.]*\) fps at p50).*/\1/p')" >> "$out/table.md"
  done
done
cat "$out/table.md"
