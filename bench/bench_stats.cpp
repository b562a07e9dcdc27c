// Min / median summaries, the aligned result table and JSON output of icube-bench.
#include "bench_stats.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <stdexcept>

namespace icube::bench {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool any_nan(const std::vector<double>& v) {
  return std::any_of(v.begin(), v.end(), [](double x) { return std::isnan(x); });
}

std::string format_number(double v, int decimals) {
  if (std::isnan(v)) return "n/a";
  std::array<char, 64> buf{};
  std::snprintf(buf.data(), buf.size(), "%.*f", decimals, v);
  return buf.data();
}

// Fewer decimals for larger numbers, so every cell has ~4 significant digits.
std::string format_ms(double ms) { return format_number(ms, ms >= 100.0 ? 1 : ms >= 10.0 ? 2 : 3); }

}  // namespace

Summary summarize(const std::vector<double>& samples_ms) {
  if (samples_ms.empty() || any_nan(samples_ms)) return {kNaN, kNaN};
  std::vector<double> s = samples_ms;
  std::sort(s.begin(), s.end());
  const size_t mid = s.size() / 2;
  const double median = s.size() % 2 ? s[mid] : 0.5 * (s[mid - 1] + s[mid]);
  return {s.front(), median};
}

double melem_per_s(uint64_t n, double ms) {
  if (std::isnan(ms) || ms <= 0.0) return kNaN;
  return static_cast<double>(n) / (ms * 1e3);
}

void print_table(const std::vector<ResultRow>& rows) {
  constexpr size_t kColumns = 7;
  const std::array<const char*, kColumns> header = {"op",        "n",       "implementation", "min ms",
                                                    "median ms", "Melem/s", "check"};
  const std::array<bool, kColumns> right_aligned = {false, true, false, true, true, true, false};
  std::vector<std::array<std::string, kColumns>> cells;
  for (const ResultRow& r : rows) {
    const Summary s = summarize(r.samples_ms);
    cells.push_back({r.op, std::to_string(r.n), r.implementation, format_ms(s.min_ms), format_ms(s.median_ms),
                     format_number(melem_per_s(r.n, s.min_ms), 1), r.check});
  }
  std::array<size_t, kColumns> width{};
  for (size_t c = 0; c < kColumns; ++c) {
    width[c] = std::string(header[c]).size();
    for (const auto& line : cells) width[c] = std::max(width[c], line[c].size());
  }
  auto print_line = [&](const std::array<std::string, kColumns>& line) {
    for (size_t c = 0; c < kColumns; ++c) {
      const int w = static_cast<int>(width[c]);
      const bool last = c + 1 == kColumns;
      if (right_aligned[c])
        std::printf("%*s", w, line[c].c_str());
      else if (last)
        std::printf("%s", line[c].c_str());  // no trailing blanks
      else
        std::printf("%-*s", w, line[c].c_str());
      std::printf(last ? "\n" : "  ");
    }
  };
  std::array<std::string, kColumns> head;
  std::array<std::string, kColumns> rule;
  for (size_t c = 0; c < kColumns; ++c) {
    head[c] = header[c];
    rule[c] = std::string(width[c], '-');
  }
  print_line(head);
  print_line(rule);
  std::string previous_group;
  for (size_t i = 0; i < cells.size(); ++i) {
    const std::string group = rows[i].op + "/" + std::to_string(rows[i].n);
    if (!previous_group.empty() && group != previous_group) std::printf("\n");
    previous_group = group;
    print_line(cells[i]);
  }
}

void print_disturbed_rows(const std::vector<ResultRow>& rows, double threshold) {
  bool first = true;
  for (const ResultRow& r : rows) {
    if (r.other_cpu_share <= threshold || r.timing == "gpu-submit") continue;  // submit shares the kernel row's runs
    if (first)
      std::printf(
          "\nnote: other processes took more than %.0f%% of the CPUs while measuring (rerun on a quiet machine):\n",
          100.0 * threshold);
    first = false;
    std::printf("  %s n=%llu %s: %.0f%%\n", r.op.c_str(), static_cast<unsigned long long>(r.n),
                r.implementation.c_str(), 100.0 * r.other_cpu_share);
  }
}

nlohmann::json row_to_json(const ResultRow& row) {
  auto number_or_null = [](double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); };
  const Summary s = summarize(row.samples_ms);
  nlohmann::json samples = nlohmann::json::array();
  for (double v : row.samples_ms) samples.push_back(number_or_null(v));
  return {{"op", row.op},
          {"n", row.n},
          {"implementation", row.implementation},
          {"timing", row.timing},
          {"samples_ms", samples},
          {"min_ms", number_or_null(s.min_ms)},
          {"median_ms", number_or_null(s.median_ms)},
          {"melem_per_s", number_or_null(melem_per_s(row.n, s.min_ms))},
          {"check", row.check},
          {"other_cpu_share", row.other_cpu_share}};
}

void write_json_file(const std::string& path, const nlohmann::json& doc) {
  std::ofstream out(path);
  if (!out) throw std::runtime_error("cannot open '" + path + "' for writing");
  out << doc.dump(2) << "\n";
  if (!out) throw std::runtime_error("failed writing '" + path + "'");
}

}  // namespace icube::bench
