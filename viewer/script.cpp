// Script parsing and frame statistics; see script.h.
#include "script.h"

#include "scene/atomic_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>

namespace icube::viewer {

namespace {

struct CommandSpec {
  size_t min_args, max_args;
  std::vector<std::string> choices;  // first argument, when non-empty
};

const std::map<std::string, CommandSpec>& command_specs() {
  static const std::map<std::string, CommandSpec> specs = {
      {"down", {1, 1, {}}},
      {"up", {1, 1, {}}},
      {"mode", {1, 1, {"drive", "fly"}}},
      {"camera", {1, 1, {"chase", "dash"}}},
      {"render", {1, 1, {"shaded", "semantic", "depth", "instance", "coords"}}},
      {"scale", {1, 1, {}}},
      {"adaptive", {1, 1, {"on", "off"}}},
      {"zero-height", {1, 1, {"on", "off"}}},
      {"autopilot", {1, 1, {"on", "off"}}},
      {"record", {1, 1, {"start", "stop", "key", "pass", "clear"}}},
      {"save", {0, 1, {}}},
      {"screenshot", {0, 1, {}}},
      {"teleport", {1, 8, {}}},
      {"shadows", {1, 1, {"on", "off"}}},
      {"ui", {1, 1, {"on", "off"}}},
      {"occupancy", {1, 1, {"on", "off"}}},
      {"ao", {1, 1, {}}},
      {"load", {0, 1, {}}},
      {"frame-shot", {3, 3, {}}},
      {"frame-shots", {2, 2, {}}},
      {"view", {1, 1, {"voxels", "gaussians"}}},
      {"time", {1, 1, {}}},
      {"play", {1, 1, {"on", "off"}}},
      {"gaussian-shots", {2, 2, {}}},
      {"quit", {0, 0, {}}},
  };
  return specs;
}

const std::vector<std::string>& key_names() {
  static const std::vector<std::string> k = {"W", "A", "S", "D", "UP", "DOWN", "LEFT", "RIGHT", "SPACE", "SHIFT", "Q", "E"};
  return k;
}

}  // namespace

std::vector<ScriptEvent> parse_script(const std::string& text, const std::string& name) {
  std::vector<ScriptEvent> out;
  std::istringstream in(text);
  std::string line;
  int n = 0;
  double last = 0.0;
  while (std::getline(in, line)) {
    ++n;
    const size_t hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    std::string time_s;
    if (!(ls >> time_s)) continue;
    auto fail = [&](const std::string& what) {
      throw std::invalid_argument(name + ":" + std::to_string(n) + ": " + what);
    };
    ScriptEvent e;
    e.line = n;
    char* end = nullptr;
    e.time = std::strtod(time_s.c_str(), &end);
    if (*end != '\0' || !std::isfinite(e.time) || e.time < 0.0) fail("bad time '" + time_s + "'");
    if (e.time < last) fail("times must not decrease");
    last = e.time;
    if (!(ls >> e.command)) fail("missing command after the time");
    for (std::string a; ls >> a;) e.args.push_back(a);
    const auto it = command_specs().find(e.command);
    if (it == command_specs().end()) fail("unknown command '" + e.command + "'");
    const CommandSpec& spec = it->second;
    if (e.args.size() < spec.min_args || e.args.size() > spec.max_args)
      fail("'" + e.command + "' takes " + std::to_string(spec.min_args) +
           (spec.max_args != spec.min_args ? ".." + std::to_string(spec.max_args) : "") + " argument(s)");
    if (!spec.choices.empty() && std::find(spec.choices.begin(), spec.choices.end(), e.args[0]) == spec.choices.end())
      fail("'" + e.command + "': unknown argument '" + e.args[0] + "'");
    if (e.command == "down" || e.command == "up") {
      std::string k = e.args[0];
      std::transform(k.begin(), k.end(), k.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
      if (std::find(key_names().begin(), key_names().end(), k) == key_names().end()) fail("unknown key '" + e.args[0] + "'");
      e.args[0] = k;
    }
    if (e.command == "ao" && e.args[0] != "off") {
      const long k = std::strtol(e.args[0].c_str(), &end, 10);
      if (*end != '\0' || k < 0 || k > 16) fail("ao takes off or a sample count 0..16");
    }
    if (e.command == "frame-shot")
      for (size_t i = 1; i < 3; ++i) {
        const long k = std::strtol(e.args[i].c_str(), &end, 10);
        if (*end != '\0' || k < 0) fail("frame-shot PATH PASS FRAME: bad index '" + e.args[i] + "'");
      }
    if (e.command == "frame-shots" || e.command == "gaussian-shots") {
      const long k = std::strtol(e.args[1].c_str(), &end, 10);
      if (*end != '\0' || k < 1) fail(e.command + " PREFIX STEP: bad step '" + e.args[1] + "'");
    }
    if (e.command == "time") {
      const long k = std::strtol(e.args[0].c_str(), &end, 10);
      if (*end != '\0' || k < 0) fail("time takes a time index >= 0");
    }
    if (e.command == "scale") {
      const double s = std::strtod(e.args[0].c_str(), &end);
      if (*end != '\0' || !(s >= 0.25 && s <= 1.0)) fail("scale must be in [0.25, 1]");
    }
    out.push_back(std::move(e));
  }
  return out;
}

std::vector<ScriptEvent> load_script(const std::string& path) { return parse_script(scene::read_file(path), path); }

std::vector<ScriptEvent> ScriptPlayer::due(double t) {
  std::vector<ScriptEvent> out;
  while (next_ < events_.size() && events_[next_].time <= t + 1e-9) out.push_back(events_[next_++]);
  return out;
}

double FrameStats::percentile(double p) const {
  if (ms.empty()) return 0.0;
  std::vector<double> v = ms;
  std::sort(v.begin(), v.end());
  const double rank = std::ceil(std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(v.size()));
  const size_t idx = static_cast<size_t>(std::max(1.0, rank)) - 1;
  return v[std::min(idx, v.size() - 1)];
}

double FrameStats::mean() const {
  return ms.empty() ? 0.0 : std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(ms.size());
}

std::string FrameStats::summary() const {
  char buf[256];
  const double p50 = percentile(50);
  std::snprintf(buf, sizeof buf, "frames %zu  mean %.2f  p50 %.2f  p90 %.2f  p95 %.2f  p99 %.2f  max %.2f ms  (%.1f fps at p50)",
                ms.size(), mean(), p50, percentile(90), percentile(95), percentile(99), percentile(100),
                p50 > 0.0 ? 1000.0 / p50 : 0.0);
  return buf;
}

}  // namespace icube::viewer
