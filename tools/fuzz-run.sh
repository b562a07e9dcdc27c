#!/usr/bin/env bash
# Builds the libFuzzer targets with clang (build-fuzz/) and fuzzes each parser
# for a short time, starting from tests/fuzz/corpus/<parser>/.
#   tools/fuzz-run.sh [--runs N] [seconds per target, default 60; 0 = no limit] [target ...]
#   tools/fuzz-run.sh --runs 10000000 0      # the 10-million-execution runs of docs/fuzzing.md
# New crashing inputs are written to build-fuzz/crash-*; minimise them and add
# them to the corpus folder of their parser so they stay regression tests.
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in -h|--help) sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
runs=()
if [ "${1:-}" = "--runs" ]; then
  runs=(-runs="${2:?--runs needs a count}")
  shift 2
fi
seconds="${1:-60}"
shift || true
CXX=clang++ CC=clang cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DICUBE_BUILD_FUZZERS=ON \
  -DICUBE_BUILD_VIEWER=OFF -DICUBE_BUILD_TESTS=OFF -DICUBE_BUILD_BENCH=OFF >/dev/null
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in tests/fuzz/fuzz_*.cpp; do targets+=("$(basename "$f" .cpp)"); done
fi
cmake --build build-fuzz -j"$(nproc)" --target "${targets[@]}"
for t in "${targets[@]}"; do
  corpus="tests/fuzz/corpus/${t#fuzz_}"
  mkdir -p "$corpus" build-fuzz/corpus-work/"$t"
  echo "== $t for ${seconds}s (corpus $corpus)"
  (cd build-fuzz && ./"$t" -max_total_time="$seconds" "${runs[@]}" -timeout=30 -rss_limit_mb=4096 \
     -print_final_stats=1 corpus-work/"$t" ../"$corpus")
done
