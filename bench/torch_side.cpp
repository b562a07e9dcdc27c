// PyTorch side of the network benchmarks; see torch_side.h.
#include "torch_side.h"

#include "world/npy.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>

namespace icube::bench {

void save_npy(const std::string& path, const nn::CpuTensor& t) {
  std::vector<uint64_t> shape(t.shape.begin(), t.shape.end());
  world::write_npy(path, world::NpyArray::make<float>(shape, t.data));
}

std::pair<int, std::string> capture(const std::string& cmd) {
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  std::string out;
  char buf[512];
  while (p && std::fgets(buf, sizeof buf, p)) out += buf;
  return {p ? pclose(p) : -1, out};
}

TorchSide::Result TorchSide::run(const nlohmann::json& c, const std::map<std::string, const nn::CpuTensor*>& inputs) const {
  Result r;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "case.json") << c.dump();
  for (const auto& [name, t] : inputs) save_npy((dir / (name + ".npy")).string(), *t);
  const std::string cmd = python + " " + ICUBE_SOURCE_DIR + "/bench/torch_nn.py --threads " + std::to_string(threads) +
                          " --runs " + std::to_string(runs) + " --warmup " + std::to_string(warmup) + " " +
                          dir.string();
  const auto [status, out] = capture(cmd);
  if (status != 0) {
    r.error = out;
    return r;
  }
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.rfind('{')));
  r.min_ms = j.at("min_ms").get<double>();
  r.median_ms = j.at("median_ms").get<double>();
  r.y = world::read_npy((dir / "y.npy").string()).values<float>();
  r.ok = true;
  return r;
}

TorchSide::Result run_torch_unet(const TorchSide& side, const std::string& config, const std::string& weights,
                                 const std::string& x, const std::string& t) {
  TorchSide::Result r;
  const std::string y = (side.dir / "unet_y.npy").string();
  const std::string cmd = side.python + " " + ICUBE_SOURCE_DIR + "/bench/torch_unet.py --config '" + config +
                          "' --weights '" + weights + "' --input '" + x + "' --timestep '" + t + "' --threads " +
                          std::to_string(side.threads) + " --runs " + std::to_string(side.runs) + " --warmup " +
                          std::to_string(side.warmup) + " -o '" + y + "'";
  const auto [status, out] = capture(cmd);
  if (status != 0 || out.find('{') == std::string::npos) {
    r.error = out;
    return r;
  }
  const nlohmann::json j = nlohmann::json::parse(out.substr(out.rfind('{')));
  r.min_ms = j.at("min_ms").get<double>();
  r.median_ms = j.at("median_ms").get<double>();
  r.y = world::read_npy(y).values<float>();
  r.ok = true;
  return r;
}

std::string python_with_torch() {
  for (const char* py : {"/usr/bin/python3", "python3"})
    if (std::system((std::string(py) + " -c 'import torch, numpy' >/dev/null 2>&1").c_str()) == 0) return py;
  return {};
}

}  // namespace icube::bench
