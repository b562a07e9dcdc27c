#!/usr/bin/env bash
# The checks for a lent GPU machine (the workplace's `device` tool), as one
# prepared run: the test suite under the validation layer on the real driver
# (tests), one forward of the released diffusion UNet at the 64^3 chunk latent
# (unet: issue 18's measurement), the benchmarks' GPU timings (bench), the
# demo town through Stages 1-3 with the CLI (lift), and issue 38's performance
# run (perf: the network kernels at the released shapes, the released UNet's
# 64^3 batch-2 forward in fp32 and fp16, a full-chunk VAE decode, splatting 1 M
# Gaussians at 1080p, then one table of them), and issue 39's GSM run (gsm: icube-bench-gsm at the released
# widths and input size, 1 and 4 key frames: time, GFLOP/s and memory per stage, the GPU against the CPU
# reference at reduced widths, Depth-Anything-V2-Large per image), and issue 38's chunk (chunk: one chunk of the
# released models, random weights of the official shapes, through `icube world build`: 100 DDIM steps with
# guidance 2 in fp16, then DPM-Solver++ at 25 steps). Pack first on this machine
# with tools/device-pack.sh; .gl/ holds Debian's libglvnd .debs (the NVIDIA
# ICD needs libGLdispatch; see the device tool's README). Then run:
#   run(command="tools/device-check.sh [unet] [tests] [bench] [lift] [perf] [gsm] [chunk]", carry=[".dev", ".gl"], timeout_s=560)
# (perf alone: ~6.5 min expected on an H100/H200, run it by itself; its steps' limits add up to ~13 min,
#  so a step that hangs to its limit lets the call's timeout cut the last steps: the table keeps what ran.
#  chunk alone: ~3-5 min expected; run it by itself after perf.)
#  gsm alone: at most ~8.5 min by its steps' limits, ~4 min expected; run it by itself.)
# Every step has its own time limit so the whole run ends inside the lease;
# logs go to $OUT (the tool brings them back), a summary is printed last.
set -u
cd "$(dirname "$0")/.."
out=${OUT:-/tmp/device-out}
mkdir -p "$out" /tmp/dev
t0=$(date +%s)
tar -C /tmp/dev -xJf .dev/lib.tar.xz && tar -C /tmp/dev -xJf .dev/bin.tar.xz || { echo "unpack failed"; exit 1; }
# libglvnd (the NVIDIA ICD's libGLX_nvidia needs it), carried as Debian .debs in .gl/.
for deb in .gl/*.deb; do [[ -f $deb ]] && dpkg -x "$deb" /tmp/dev/gl; done
export LD_LIBRARY_PATH=/tmp/dev/lib:/tmp/dev/gl/usr/lib/x86_64-linux-gnu VK_LAYER_PATH=/tmp/dev/layers
nv_icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
[[ -f $nv_icd ]] && export VK_DRIVER_FILES=$nv_icd
# The test binary looks for assets under the checkout it was built in.
built_in=/work/main
if [[ ! -e $built_in/assets ]]; then mkdir -p "$(dirname $built_in)" && ln -sfn "$PWD" "$built_in"; fi
bin=/tmp/dev/bin
steps="$*"  # a subset of: unet tests bench lift perf gsm (default: all but perf and gsm)
summary=()
step() {  # step NAME LIMIT_S CMD...: runs CMD with a limit, log in $out/NAME.txt
  local name=$1 limit=$2; shift 2
  local s; s=$(date +%s)
  timeout -s KILL "$limit" "$@" >"$out/$name.txt" 2>&1
  local rc=$? e=$(( $(date +%s) - s ))
  summary+=("$(printf '%-14s rc %3d  %4d s' "$name" "$rc" "$e")")
  echo "== $name: rc $rc, $e s (t+$(( $(date +%s) - t0 )) s)"
  tail -n 25 "$out/$name.txt"
}
nvidia-smi --query-gpu=name,driver_version,clocks.sm,memory.used --format=csv 2>&1 | tee "$out/gpu.txt"
ls /usr/local/nvidia/share/vulkan/icd.d /usr/share/vulkan/icd.d /etc/vulkan/icd.d 2>&1 | head
step devices 30 env VK_LOADER_DEBUG=error,warn,driver "$bin/icube" devices
grep -qi "NVIDIA" "$out/devices.txt" || { echo "no NVIDIA Vulkan device: stopping"; exit 1; }
want() { [[ ( -z $steps && $1 != perf && $1 != gsm && $1 != chunk ) || " $steps " == *" $1 "* ]]; }
if want unet; then
  # Issue 18: one forward of the released UNet (812 M parameters) at 64^3, batch 1, fp32 and fp16 (weights and operands).
  step unet64 160 "$bin/icube-bench-nn" --only none --unet infinicube-diffusion --unet-grid 64 64 64 \
    --unet-no-cpu --runs 5 --warmup 1
  step unet64_fp16 80 "$bin/icube-bench-nn" --only none --unet infinicube-diffusion --unet-grid 64 64 64 \
    --unet-no-cpu --unet-precision fp16 --runs 5 --warmup 1
fi
if want tests; then
  # The whole suite on the real driver, validation layer on (data-set cases skip: no ../shared here).
  step tests 170 "$bin/icube-tests" --duration=true
  grep -E "^\[doctest\] (test cases|assertions)|Status:" "$out/tests.txt" | tail -3
fi
if want bench; then
  step bench_splat 45 "$bin/icube-bench-splat" --gaussians 1000000 --sizes 1920x1080 --runs 5 --no-cpu
  step bench_raycast 45 "$bin/icube-bench-raycast" --case demo --runs 5 --cpu-threads 16
  step bench_frames 40 "$bin/icube-bench-frames" --runs 5 --warmup 1
  step bench_lift 90 "$bin/icube-bench-lift" --runs 5 --warmup 1
fi
if want lift; then
  # Stage 1 to 3 on the demo town with the CLI, timed: world, 30 frames, lift.
  d=/tmp/dev/demo; mkdir -p $d
  "$bin/icube" world demo-scene -o $d/scene.json >/dev/null 2>&1
  step demo_world 60 "$bin/icube" world build $d/scene.json -o $d/world.icw
  step demo_frames 60 "$bin/icube" frames render $d/world.icw --scene $d/scene.json --frames 0:60:2 -o $d/frames
  step demo_lift 60 "$bin/icube" lift $d/world.icw $d/frames --scene $d/scene.json -o $d/lifted
  cp $d/lifted/eval.png "$out/" 2>/dev/null
fi
if want perf; then
  # Issue 38: the learned stages at GPU speed. The kernels run side by side in one process (conv3d:
  # register = the lavapipe kernel the GPU used before, tiled, tiled-fp16, coopmat-fp16; attention:
  # per-query and tiled), and the UNet forward with ICUBE_NN_KERNELS=lavapipe (the old kernels) against
  # the default (new) on the same warm machine. The GPU kernels' tests run first: a wrong cooperative-
  # matrix result fails here.
  step perf_tests 120 "$bin/icube-tests" -tc="conv3d gpu*,sparse conv gpu*,attention gpu*,group_norm gpu*,layer_norm gpu*,layer recorder*,dpm*,unet gpu*,vae gpu*" --duration=true
  grep -E "^\[doctest\] (test cases|assertions)|Status:" "$out/perf_tests.txt" | tail -3
  step perf_kernels 100 "$bin/icube-bench-nn" --only released --released-levels --runs 5 --warmup 1 --cpu-limit 0
  step perf_unet_fp32_old 100 env ICUBE_NN_KERNELS=lavapipe "$bin/icube-bench-nn" --only none --unet infinicube-diffusion \
    --unet-grid 64 64 64 --unet-batch 2 --unet-no-cpu --runs 3 --warmup 1
  step perf_unet_fp32 60 "$bin/icube-bench-nn" --only none --unet infinicube-diffusion --unet-grid 64 64 64 \
    --unet-batch 2 --unet-no-cpu --runs 5 --warmup 1
  step perf_unet_fp16_old 80 env ICUBE_NN_KERNELS=lavapipe "$bin/icube-bench-nn" --only none --unet infinicube-diffusion \
    --unet-grid 64 64 64 --unet-batch 2 --unet-no-cpu --unet-precision fp16 --runs 3 --warmup 1
  step perf_unet_fp16 60 "$bin/icube-bench-nn" --only none --unet infinicube-diffusion --unet-grid 64 64 64 \
    --unet-batch 2 --unet-no-cpu --unet-precision fp16 --runs 5 --warmup 1
  # fp16 weights alone (fp32 convolution operands): what storing the norms' outputs as fp16 saves.
  step perf_unet_fp16w 45 "$bin/icube-bench-nn" --only none --unet infinicube-diffusion --unet-grid 64 64 64 \
    --unet-batch 2 --unet-no-cpu --unet-precision fp16-weights --runs 3 --warmup 1
  step perf_vae 60 "$bin/icube-bench-sparse" --vae-decode 64 64 64 --vae-model infinicube-vae --runs 3 --warmup 1
  step perf_vae_fp16 45 "$bin/icube-bench-sparse" --vae-decode 64 64 64 --vae-model infinicube-vae --vae-precision fp16 \
    --runs 3 --warmup 1
  # The sparse kernels side by side on a whole chunk of the demo world (the first row checked against the dense conv).
  step perf_sparse 60 "$bin/icube-bench-sparse" --case demo --box 256 256 128 --channels 64 128 \
    --sparse-paths register,tiled,tiled-fp16,coopmat,coopmat-fp16 --runs 5 --warmup 1 --dense-runs 1
  step perf_splat 45 "$bin/icube-bench-splat" --gaussians 1000000 --sizes 1920x1080 --runs 5 --no-cpu
  {
    echo "| measurement | result |"
    echo "|---|---|"
    grep -E "^\[doctest\] test cases" "$out/perf_tests.txt" | sed -E 's/^/| perf_tests | /; s/$/ |/'
    grep -E "^released" "$out/perf_kernels.txt" | sed -E 's/^(.{30})(.*)$/| \1 | \2 |/'
    for f in perf_unet_fp32_old perf_unet_fp32 perf_unet_fp16_old perf_unet_fp16 perf_unet_fp16w; do
      grep -E "^UNet forward|GFLOP in convolutions" "$out/$f.txt" | sed -E "s/^ */| $f | /; s/$/ |/"
    done
    for f in perf_vae perf_vae_fp16; do
      grep -iE "decode" "$out/$f.txt" | tail -n 3 | sed -E "s/^/| $f | /; s/$/ |/"
    done
    grep -E "^(sparse |dense conv3d)" "$out/perf_sparse.txt" | sed -E 's/^/| perf_sparse | /; s/$/ |/'
    grep -E "1920x1080" "$out/perf_splat.txt" | tail -n 3 | sed -E 's/^/| perf_splat | /; s/$/ |/'
  } > "$out/perf_table.md"
  cat "$out/perf_table.md"
fi
if want gsm; then
  # Issue 39: the GSM on the GPU. First the GPU forward against the CPU reference (one CPU thread) at reduced widths
  # (gsm_small's) on the benchmark's street at 480 x 832, 1 and 4 views; then the released widths (360.7 M random
  # parameters) at 1 and 4 key frames, 5 runs after a warm-up, per stage time / GFLOP/s / peak RSS, the device's
  # weights and activation pool; then Depth-Anything-V2-Large per image (PyTorch's row skips without python3-torch).
  step gsm_check 200 "$bin/icube-bench-gsm" --views 1,4 --no-released --no-dav2
  step gsm 300 "$bin/icube-bench-gsm" --views 1,4 --runs 5 --warmup 1 --no-check --dav2-runs 5 --dav2-warmup 1 --dav2-parts
  {
    echo "| measurement | result |"
    echo "|---|---|"
    grep -E "^[0-9]+ +[0-9.]+ +[0-9.]+ .*(ok|FAIL)$" "$out/gsm_check.txt" | sed -E 's/^/| gsm_check views | /; s/$/ |/'
    grep -E "^(image features|sky token|pixel rays|voxel branch|pixel branch|sky colours|whole forward|device memory|[0-9]+ views?)" \
      "$out/gsm.txt" | sed -E 's/^/| gsm | /; s/$/ |/'
    grep -E "^engine (GPU|output)|^= " "$out/gsm.txt" | sed -E 's/^/| gsm dav2 | /; s/$/ |/'
  } > "$out/gsm_table.md"
  cat "$out/gsm_table.md"
fi
if want chunk; then
  # Issue 38's "a 100-step guidance-2 chunk <= 40 s (and with DPM-Solver++ at the steps the table gives)": the
  # released UNet and VAE (random weights of the official shapes) on the demo town's first chunk. The summary's
  # "chunk 0:" line splits it into conditions, sampling and decode; the weights' making is not timed.
  d=/tmp/dev/chunk; mkdir -p $d
  "$bin/icube" world demo-scene -o $d/scene.json >/dev/null 2>&1
  step chunk_weights 150 sh -c "'$bin/icube' nn random-weights --model infinicube-diffusion --seed 1 -o $d/unet.safetensors \
    && '$bin/icube' nn random-weights --vae-model infinicube-vae --seed 2 -o $d/vae.safetensors"
  models="--generator diffusion --model infinicube-diffusion --weights $d/unet.safetensors --vae $d/vae.safetensors \
    --vae-model infinicube-vae --scale-factor 1 --max-chunks 1 --no-vehicles --precision fp16"
  step chunk_ddim100 200 "$bin/icube" world build $d/scene.json $models --steps 100 --cfg 2 -o $d/ddim100.icw
  step chunk_dpm25 100 "$bin/icube" world build $d/scene.json $models --sampler dpm++2m --steps 25 --cfg 2 -o $d/dpm25.icw
  {
    echo "| measurement | result |"
    echo "|---|---|"
    for f in chunk_ddim100 chunk_dpm25; do
      grep -E "^  chunk 0:|^  diffusion:|^  time " "$out/$f.txt" | sed -E "s/^ */| $f | /; s/$/ |/"
    done
  } > "$out/chunk_table.md"
  cat "$out/chunk_table.md"
fi
echo "== summary (t+$(( $(date +%s) - t0 )) s)"
printf '%s\n' "${summary[@]}"
