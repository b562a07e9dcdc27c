#!/usr/bin/env bash
# Builds the suite with AddressSanitizer + UndefinedBehaviorSanitizer into
# build-sanitize/ (viewer and benchmarks off, shaders with debug info: the
# option set CI configures) and runs icube-tests under them on lavapipe.
#
#   tools/sanitize-run.sh                 # the whole suite but the "slow-gpu" suite (~23 min on 2 cores)
#   tools/sanitize-run.sh --cpu-only      # the CPU-side tests alone (icube-tests-cpu: scene/ readers,
#                                         # world/ containers, meshes, plans; ~5 min; as CI runs it)
#   tools/sanitize-run.sh -- -tc='*npy*'  # any doctest arguments after --
#   ICUBE_SANITIZE=thread tools/sanitize-run.sh -- -tc='world build*'   # ThreadSanitizer instead
#
# Every finding is fatal (-fno-sanitize-recover=all, halt_on_error). Leaks inside
# the uninstrumented Vulkan driver stack are suppressed (tools/sanitizers/lsan.supp).
set -euo pipefail
cd "$(dirname "$0")/.."

cpu_only=0
args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --cpu-only) cpu_only=1; shift ;;
    --) shift; args+=("$@"); break ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "sanitize-run: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

sanitizers="${ICUBE_SANITIZE:-address,undefined}"
dir="build-sanitize"
[ "$sanitizers" = "address,undefined" ] || dir="build-sanitize-${sanitizers//,/-}"
werror=OFF
[ "${CI:-}" = "true" ] && werror=ON
# -O1: what the sanitizers' documentation recommends, and a quicker build than -O3 (CI's time).
cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
  -DICUBE_SANITIZE="$sanitizers" -DICUBE_WERROR="$werror" \
  -DICUBE_BUILD_VIEWER=OFF -DICUBE_BUILD_BENCH=OFF -DICUBE_SHADER_DEBUG=ON >/dev/null
if [ $cpu_only = 1 ]; then
  cmake --build "$dir" -j"$(nproc)" --target icube-tests-cpu
else
  cmake --build "$dir" -j"$(nproc)"
fi

supp="$PWD/tools/sanitizers/lsan.supp"
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1"
# The Vulkan loader unloads lavapipe at vkDestroyInstance, so at exit LeakSanitizer sees lavapipe's
# one-time allocations with "<unknown module>" frames that no suppression can name. Preloading the
# ICD keeps it mapped (its allocations then stay reachable or are attributed); the preload puts it
# before the ASan runtime in the library list, which verify_asan_link_order=0 allows.
lvp_json=/usr/share/vulkan/icd.d/lvp_icd.x86_64.json
if [[ "$sanitizers" == *address* ]] && [ -f "$lvp_json" ]; then
  lvp_lib=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' "$lvp_json")
  if [ -f "$lvp_lib" ]; then
    export LD_PRELOAD="$lvp_lib${LD_PRELOAD:+:$LD_PRELOAD}"
    ASAN_OPTIONS="$ASAN_OPTIONS:verify_asan_link_order=0"
  fi
fi
export LSAN_OPTIONS="suppressions=$supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1"
echo "== icube-tests under $sanitizers ($dir)"
# The test suite "slow-gpu" (end-to-end runs of the tiny diffusion model and the VAE on 64^3 chunks:
# minutes of lavapipe work whose host code other cases cover) runs in the plain suite only.
if [ $cpu_only = 1 ]; then
  "$dir/icube-tests-cpu" "${args[@]}"
else
  "$dir/icube-tests" --test-suite-exclude=slow-gpu "${args[@]}"
fi
