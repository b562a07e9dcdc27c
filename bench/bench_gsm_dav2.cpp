// icube-bench-gsm's Depth-Anything-V2 table: Depth-Anything-V2-Large on one image, the engine's GPU
// stage (optionally its CPU reference, optionally cut short to split the time) against PyTorch's CPU run
// of the same module (bench/dav2_torch.py) on the same weights and input. See bench/gsm_bench.h.
#include "gsm_bench.h"
#include "gsm_flops.h"
#include "gsm_street_scene.h"
#include "torch_side.h"

#include "gpu/context.h"
#include "nn/gsm/dav2_gpu.h"
#include "nn/gsm/dav2_reference.h"
#include "nn/gsm/gsm_gpu_weights.h"
#include "nn/layer_recorder.h"
#include "nn/parameter_store.h"
#include "nn/safetensors.h"
#include "world/npy.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace icube::bench {

namespace {

struct Dav2Part {
  double seconds = 0, flops = 0;
};

// The Depth-Anything-V2 tensors as a .safetensors file for bench/dav2_torch.py (state-dict names, F32; the
// BatchNorm counters left out) and the settings the script needs.
void write_dav2_for_torch(const std::filesystem::path& dir, const nn::Dav2Config& c, const nn::GsmWeights& w,
                          const nn::CpuTensor& image) {
  std::vector<nn::TensorToWrite> tensors;
  for (const auto& [name, t] : w.tensors)
    if (name.rfind("img_encoder.encoders.dav2.", 0) == 0 && name.find("num_batches_tracked") == std::string::npos)
      tensors.push_back(nn::f32_tensor(name, t.shape, t.data));
  nn::write_safetensors((dir / "dav2.safetensors").string(), tensors);
  nlohmann::json j;
  j["hidden_size"] = c.hidden_size;
  j["num_layers"] = c.num_layers;
  j["num_heads"] = c.num_heads;
  j["patch_size"] = c.patch_size;
  j["position_grid"] = c.position_grid;
  j["layer_norm_eps"] = c.layer_norm_eps;
  j["out_indices"] = c.out_indices;
  j["reassemble_factors"] = c.reassemble_factors;
  j["input_size"] = {c.input_height, c.input_width};
  nlohmann::json up = nlohmann::json::array();
  for (const nn::Dav2UpsamplerBlock& b : c.upsampler) up.push_back({{"out_dim", b.out_dim}, {"up", b.up}});
  j["upsampler"] = up;
  std::ofstream(dir / "dav2.json") << j.dump(1);
  bench::save_npy((dir / "image.npy").string(), image);
}

}  // namespace

void GsmBench::dav2_table(const nn::GsmModelConfig& model, const nn::GsmWeights& w) {
  const nn::Dav2Config& cfg = model.config.dav2;
  nn::check_dav2_gpu(cfg, model.config.source);
  const nn::CpuTensor image = nn::gsm_images_nchw(bench::first_views(scene, 1));  // [1, 3, H, W]
  const double gflop = bench::dav2_flops_per_view(cfg, w) * 1e-9;
  const int64_t gh = cfg.input_height / cfg.patch_size, gw = cfg.input_width / cfg.patch_size;
  std::printf("\nDepth-Anything-V2-Large on one image: %lld x %lld resized to %lld x %lld, %lld x %lld patches (%lld tokens), "
              "%d layers run; %.1f GFLOP\n",
              static_cast<long long>(o.height), static_cast<long long>(o.width), static_cast<long long>(cfg.input_height),
              static_cast<long long>(cfg.input_width), static_cast<long long>(gh), static_cast<long long>(gw),
              static_cast<long long>(1 + gh * gw), static_cast<int>(*std::max_element(cfg.out_indices.begin(), cfg.out_indices.end())),
              gflop);

  // The engine on the device: a store of the stage's own tensors.
  std::unique_ptr<nn::ParameterStore> store;
  {
    const nn::GsmGpuWeights all = nn::gsm_gpu_weights(w);
    std::vector<nn::ParamSpec> specs;
    for (const nn::ParamSpec& p : all.specs)
      if (p.name.rfind("img_encoder.encoders.dav2.", 0) == 0) specs.push_back(p);
    store = std::make_unique<nn::ParameterStore>(*ctx, specs, all.tensors,
                                                 nn::ParameterStoreOptions{.network = "Depth-Anything-V2", .source = "random weights"});
  }
  std::vector<double> gpu_s;
  nn::CpuTensor gpu_out;
  DisturbanceMeter gpu_meter;
  std::vector<std::pair<std::string, Dav2Part>> parts;
  {
    nn::LayerRecorder L(*ctx, *store, "dav2-bench");
    nn::Dav2PositionEmbeddings positions;
    const nn::DeviceTensor x{std::make_shared<gpu::Buffer>(gpu::upload_vector(*ctx, image.data, "dav2-image")), image.shape};
    nn::DeviceTensor y;
    auto run = [&](const nn::Dav2Config& c) {
      y = {};
      const Clock::time_point t0 = Clock::now();
      ctx->submit_and_wait([&](gpu::CommandList& cmd) {
        L.begin(cmd);
        y = nn::dav2_gpu(L, c, x, nullptr, &positions);
        L.end();
      });
      return seconds_since(t0);
    };
    for (int r = 0; r < o.dav2_warmup + o.dav2_runs; ++r) {
      std::fprintf(stderr, "  Depth-Anything-V2 GPU: %s %d ...\n", r < o.dav2_warmup ? "warm-up" : "run",
                   r < o.dav2_warmup ? r + 1 : r - o.dav2_warmup + 1);
      if (r == o.dav2_warmup) gpu_meter.start();
      const double s = run(cfg);
      if (r >= o.dav2_warmup) gpu_s.push_back(s);
    }
    gpu_meter.stop();
    gpu_out = nn::CpuTensor(y.shape, gpu::download_vector<float>(*ctx, *y.buf, y.numel()));
    std::printf("engine output %s, activation pool %.0f MiB, weights %.0f MiB on the device\n", gpu_out.shape_text().c_str(),
                mib(static_cast<double>(L.pool().bytes())), mib(static_cast<double>(store->device_bytes())));
    if (o.dav2_parts) {
      // The same stage cut short, one run each: without the upsampler, then with only 4 and 0 transformer layers.
      nn::Dav2Config no_up = cfg;
      no_up.upsampler.clear();
      nn::Dav2Config four = no_up, none = no_up;
      four.out_indices = {1, 2, 3, 4};
      none.out_indices = {0, 0, 0, 0};
      for (const auto& [label, c] : {std::make_pair("backbone + neck, no upsampler", no_up),
                                     std::make_pair("4 layers + neck", four), std::make_pair("embeddings + neck", none)}) {
        std::fprintf(stderr, "  Depth-Anything-V2 GPU part: %s ...\n", label);
        parts.emplace_back(label, Dav2Part{run(c), bench::dav2_flops_per_view(c, w)});
      }
    }
  }
  store.reset();

  nn::CpuTensor cpu_out;
  double cpu_s = kNaN;
  DisturbanceMeter cpu_meter;
  if (o.dav2_cpu) {
    std::fprintf(stderr, "  Depth-Anything-V2 CPU reference ...\n");
    cpu_meter.start();
    const Clock::time_point t0 = Clock::now();
    cpu_out = nn::dav2_features(cfg, w, image);
    cpu_s = seconds_since(t0);
    cpu_meter.stop();
  }

  // PyTorch, once per matmul route (bench/dav2_torch.py --matmul).
  struct TorchRow {
    std::string matmul, note;
    int runs = 0;
    bench::TorchSide::Result r;
    DisturbanceMeter meter;
  };
  std::vector<TorchRow> torch_rows;
  const int torch_threads = lp_threads > 0 ? lp_threads : static_cast<int>(std::max(1u, bench::online_cpus()));
  const std::string python = o.torch ? bench::python_with_torch() : "";
  std::string torch_skipped;
  if (!o.torch) {
    torch_skipped = "skipped (--no-torch)";
  } else if (python.empty()) {
    torch_skipped = "skipped: no python3 with torch and numpy (Debian python3-torch)";
  } else {
    const std::filesystem::path dir = o.keep_dir.empty()
                                          ? std::filesystem::temp_directory_path() / ("icube-bench-gsm-" + std::to_string(getpid()))
                                          : std::filesystem::path(o.keep_dir);
    std::filesystem::create_directories(dir);
    std::fprintf(stderr, "  PyTorch: writing the weights to %s ...\n", dir.c_str());
    write_dav2_for_torch(dir, cfg, w, image);
    for (const std::string& matmul : o.torch_matmul) {
      TorchRow row;
      row.matmul = matmul;
      row.runs = matmul == "blas" ? o.torch_blas_runs : o.torch_runs;
      const int warmup = matmul == "blas" ? 0 : o.torch_warmup;
      const std::string cmd = python + " " + ICUBE_SOURCE_DIR + "/bench/dav2_torch.py --dir '" + dir.string() + "' --threads " +
                              std::to_string(torch_threads) + " --runs " + std::to_string(row.runs) + " --warmup " +
                              std::to_string(warmup) + " --matmul " + matmul;
      std::fprintf(stderr, "  PyTorch: %s\n", cmd.c_str());
      row.meter.start();
      const auto [status, text] = bench::capture(cmd);
      row.meter.stop();
      if (status != 0 || text.find('{') == std::string::npos) {
        row.note = "FAILED (see stderr)";
        std::fprintf(stderr, "dav2_torch.py failed:\n%s\n", text.c_str());
        failed = true;
      } else {
        const nlohmann::json j = nlohmann::json::parse(text.substr(text.rfind('{')));
        row.r.min_ms = j.at("min_ms").get<double>();
        row.r.median_ms = j.at("median_ms").get<double>();
        row.r.y = world::read_npy((dir / "y.npy").string()).values<float>();
        row.r.ok = true;
        row.note = "PyTorch " + j.value("torch", std::string("?")) + " CPU, " + (matmul == "blas" ? "BLAS matmuls" : "oneDNN matmuls");
      }
      torch_rows.push_back(std::move(row));
    }
    if (o.keep_dir.empty()) std::filesystem::remove_all(dir);
  }

  auto diff = [](const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && !a.empty() ? nn::cpu::max_abs_over_std(a, b) : kNaN;
  };
  const std::vector<float>* reference = nullptr;  // the first PyTorch output
  for (const TorchRow& t : torch_rows)
    if (t.r.ok && !reference) reference = &t.r.y;
  std::printf("%-44s %8s %10s %10s %9s %5s %7s  %s\n", "implementation", "threads", "min s", "median s", "GFLOP/s", "runs",
              "other%", "max |diff| / std(torch)");
  const MinMedian g = min_median(gpu_s);
  const std::string device = "engine GPU (" + ctx->info().name + ")";
  std::printf("%-44.44s %8s %10.2f %10.2f %9.1f %5d %7.0f  %.2e\n", device.c_str(),
              lp_threads > 0 ? std::to_string(lp_threads).c_str() : "-", g.min, g.median, gflop / g.min, o.dav2_runs,
              gpu_meter.percent(), reference ? diff(gpu_out.data, *reference) : kNaN);
  if (o.dav2_cpu)
    std::printf("%-44s %8d %10.2f %10.2f %9.1f %5d %7.0f  %.2e (GPU against it: %.2e)\n", "engine CPU reference (dav2_features)", 1,
                cpu_s, cpu_s, gflop / cpu_s, 1, cpu_meter.percent(), reference ? diff(cpu_out.data, *reference) : kNaN,
                diff(gpu_out.data, cpu_out.data));
  for (const TorchRow& t : torch_rows) {
    if (!t.r.ok) {
      std::printf("%-44s %s\n", ("PyTorch (--matmul " + t.matmul + ")").c_str(), t.note.c_str());
      continue;
    }
    char against[32] = "-";  // the first PyTorch row is the reference
    if (&t.r.y != reference) std::snprintf(against, sizeof against, "%.2e", diff(t.r.y, *reference));
    std::printf("%-44.44s %8d %10.2f %10.2f %9.1f %5d %7.0f  %s\n", t.note.c_str(), torch_threads, t.r.min_ms * 1e-3,
                t.r.median_ms * 1e-3, gflop / (t.r.min_ms * 1e-3), t.runs, t.meter.percent(), against);
  }
  if (!torch_skipped.empty()) std::printf("%-44s %s\n", "PyTorch CPU (bench/dav2_torch.py)", torch_skipped.c_str());
  if (!parts.empty()) {
    std::printf("\nwhere the engine's time goes (one run each, the same device and input):\n");
    std::printf("%-44s %10s %9s %9s\n", "part", "s", "GFLOP", "GFLOP/s");
    const double full = g.min, full_flops = gflop * 1e9;
    const Dav2Part& a24 = parts[0].second;
    const Dav2Part& a4 = parts[1].second;
    const Dav2Part& a0 = parts[2].second;
    const int64_t layers = std::min(cfg.num_layers, *std::max_element(cfg.out_indices.begin(), cfg.out_indices.end()));
    auto row = [](const char* label, double sec, double flops) {
      std::printf("%-44s %10.2f %9.1f %9.1f\n", label, sec, flops * 1e-9, sec > 0 ? flops * 1e-9 / sec : 0.0);
    };
    for (const auto& [label, p] : parts) row(label.c_str(), p.seconds, p.flops);
    row("= upsampler (full - no upsampler)", full - a24.seconds, full_flops - a24.flops);
    row("= one transformer layer ((4 - 0 layers) / 4)", (a4.seconds - a0.seconds) / 4, (a4.flops - a0.flops) / 4);
    const std::string all = "= all " + std::to_string(layers) + " transformer layers (" + std::to_string(layers) + " - 0 layers)";
    row(all.c_str(), a24.seconds - a0.seconds, a24.flops - a0.flops);
  }
  const double tolerance = 1e-4;
  if (reference && !(diff(gpu_out.data, *reference) <= tolerance)) {
    std::fprintf(stderr, "Depth-Anything-V2: the engine's output differs from PyTorch's by more than %.0e of its std\n", tolerance);
    failed = true;
  }
  std::fflush(stdout);
}

}  // namespace icube::bench
