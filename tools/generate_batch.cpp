#include "generate_batch.h"

#include "cli_common.h"

#include "scene/atomic_file.h"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <stdexcept>

namespace icube::tools {

namespace fs = std::filesystem;

std::vector<BatchScene> read_batch_list(const std::string& list) {
  const std::string text = scene::read_file(list);
  const fs::path base = fs::path(list).parent_path();
  std::vector<BatchScene> out;
  std::map<std::string, size_t> line_of_name;
  size_t line = 0;
  for (size_t pos = 0; pos < text.size();) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string s = text.substr(pos, end - pos);
    pos = end + 1;
    ++line;
    const size_t a = s.find_first_not_of(" \t\r"), b = s.find_last_not_of(" \t\r");
    if (a == std::string::npos || s[a] == '#') continue;
    s = s.substr(a, b - a + 1);
    BatchScene bs;
    bs.line = line;
    bs.scene = fs::path(s).is_absolute() ? s : (base / s).lexically_normal().string();
    bs.package = fs::path(s).stem().string();
    if (bs.package.empty() || bs.package[0] == '.')
      throw scene::InputError(list, "line " + std::to_string(line), "no package name in '" + scene::printable(s) + "'");
    const auto [it, fresh] = line_of_name.emplace(bs.package, line);
    if (!fresh)
      throw scene::InputError(list, "line " + std::to_string(line),
                              "package name '" + bs.package + "' is also line " + std::to_string(it->second) +
                                  "'s (packages are named by the scene file's stem)");
    out.push_back(std::move(bs));
  }
  if (out.empty()) throw scene::InputError(list, "", "lists no scene");
  return out;
}

Shard parse_shard(const std::string& text) {
  const size_t slash = text.find('/');
  Shard s;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("no '/'");
    size_t used = 0;
    const std::string i = text.substr(0, slash), n = text.substr(slash + 1);
    const long long iv = std::stoll(i, &used);
    if (used != i.size()) throw std::invalid_argument("index");
    const long long nv = std::stoll(n, &used);
    if (used != n.size()) throw std::invalid_argument("count");
    if (nv < 1 || iv < 0 || iv >= nv) throw std::invalid_argument("range");
    s.index = static_cast<size_t>(iv);
    s.count = static_cast<size_t>(nv);
  } catch (const std::exception&) {
    throw std::invalid_argument("--shard '" + scene::printable(text) + "': expected I/N with 0 <= I < N (e.g. 0/4)");
  }
  return s;
}

size_t run_generate_batch(const pipeline::GenerateArgs& base, const std::string& list, const Shard& shard) {
  if (base.output.empty()) throw std::invalid_argument("give -o OUT_ROOT (the packages go into it)");
  const std::vector<BatchScene> all = read_batch_list(list);
  std::vector<const BatchScene*> mine;
  for (size_t i = shard.index; i < all.size(); i += shard.count) mine.push_back(&all[i]);
  const fs::path root = fs::absolute(base.output);
  fs::create_directories(root);
  std::fprintf(stderr, "batch: %s, shard %zu/%zu: %zu of %zu scenes -> %s\n", list.c_str(), shard.index, shard.count,
               mine.size(), all.size(), root.c_str());

  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  size_t failed = 0, counts[4] = {0, 0, 0, 0};  // generated, resumed, skipped, failed
  for (size_t k = 0; k < mine.size(); ++k) {
    const BatchScene& bs = *mine[k];
    std::fprintf(stderr, "batch: [%zu/%zu] %s -> %s\n", k + 1, mine.size(), bs.scene.c_str(), bs.package.c_str());
    pipeline::GenerateArgs a = base;
    report_on_terminal(a);  // fresh progress bars per scene
    a.path.scene = bs.scene;
    a.output = (root / bs.package).string();
    a.resume = true;
    nlohmann::ordered_json row = {{"line", bs.line}, {"scene", bs.scene}, {"package", bs.package}};
    const auto t0 = std::chrono::steady_clock::now();
    scene::Diagnostics diag;
    try {
      const pipeline::GenerateResult r = pipeline::generate_package(a, diag);
      const char* status = r.skipped ? "skipped" : r.resumed_stages ? "resumed" : "generated";
      row["status"] = status;
      ++counts[r.skipped ? 2 : r.resumed_stages ? 1 : 0];
      if (r.resumed_stages) row["resumed_after"] = pipeline::generate_stage_names()[r.resumed_stages - 1];
      if (!r.skipped) print_generate_summary(r, bs.scene);
    } catch (const std::exception& e) {
      row["status"] = "failed";
      row["error"] = e.what();
      ++failed;
      ++counts[3];
      std::fprintf(stderr, "icube: error: %s (%s, list line %zu)\n", e.what(), bs.scene.c_str(), bs.line);
    }
    print_warnings(diag);
    row["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    rows.push_back(row);
  }

  nlohmann::ordered_json report = {{"list", fs::absolute(list).string()},
                                   {"shard", shard.index},
                                   {"shards", shard.count},
                                   {"scenes_in_list", all.size()},
                                   {"generated", counts[0]},
                                   {"resumed", counts[1]},
                                   {"skipped", counts[2]},
                                   {"failed", counts[3]},
                                   {"scenes", rows}};
  const fs::path rpath =
      root / ("shard-" + std::to_string(shard.index) + "-of-" + std::to_string(shard.count) + ".report.json");
  scene::write_file_atomic(rpath.string(), report.dump(1) + "\n");
  std::printf("batch shard %zu/%zu: %zu scenes: %zu generated, %zu resumed, %zu skipped (complete), %zu failed\n",
              shard.index, shard.count, mine.size(), counts[0], counts[1], counts[2], counts[3]);
  std::printf("%-6s %-24s %-10s %10s  %s\n", "line", "package", "status", "seconds", "error");
  for (const auto& r : rows)
    std::printf("%-6zu %-24s %-10s %10.1f  %s\n", r["line"].get<size_t>(), r["package"].get<std::string>().c_str(),
                r["status"].get<std::string>().c_str(), r["seconds"].get<double>(),
                r.contains("error") ? r["error"].get<std::string>().c_str() : "");
  std::printf("report: %s\n", rpath.c_str());
  return failed;
}

}  // namespace icube::tools
