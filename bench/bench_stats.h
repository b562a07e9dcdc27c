// Benchmark bookkeeping for icube-bench: per-implementation timing samples,
// their min / median, throughput, the aligned result table and the JSON file.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace icube::bench {

// Min and median of a set of samples in milliseconds (NaN when there are none
// or any is NaN, e.g. GPU timestamps unsupported).
struct Summary {
  double min_ms = 0.0;
  double median_ms = 0.0;
};

Summary summarize(const std::vector<double>& samples_ms);

// Million elements per second for `n` elements processed in `ms` (NaN for NaN or 0 ms).
double melem_per_s(uint64_t n, double ms);

// One line of the result table: one implementation of one op at one size.
struct ResultRow {
  std::string op;              // "scan", "sort32", "sort64"
  uint64_t n = 0;              // elements
  std::string implementation;  // e.g. "gpu RadixSort Bits32: kernel"
  std::string timing;          // "gpu-kernel", "gpu-submit", "transfer", "cpu"
  std::vector<double> samples_ms;
  std::string check;             // "ok", "FAIL", "skip", or "-" (not a result-producing row)
  double other_cpu_share = 0.0;  // CPU share other processes took during the runs (0..1)
};

// Prints the rows as an aligned table with the columns
// op, n, implementation, min ms, median ms, Melem/s, check.
void print_table(const std::vector<ResultRow>& rows);

// Prints a note naming the rows measured while other processes took more than
// `threshold` of the CPUs (their numbers are likely too slow).
void print_disturbed_rows(const std::vector<ResultRow>& rows, double threshold);

// One row as JSON (samples, min, median, Melem/s; NaN becomes null).
nlohmann::json row_to_json(const ResultRow& row);

// Writes `doc` to `path` (pretty-printed); throws std::runtime_error on I/O errors.
void write_json_file(const std::string& path, const nlohmann::json& doc);

}  // namespace icube::bench
