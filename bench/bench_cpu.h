// CPU competitors of the GPU primitives in icube-bench: std::inclusive_scan,
// std::stable_sort and std::sort of (key, value) pairs, single-threaded or
// split over `threads` std::threads (chunked two-pass scan; sorted chunks
// merged with std::inplace_merge), so the CPU side can use as many threads as
// lavapipe (LP_NUM_THREADS).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace icube::bench {

// Array-of-structs element the CPU sorts (the GPU sorts separate key and value arrays).
template <class K>
struct KeyValue {
  K key;
  uint32_t value;
};

// out[i] = in[0] + ... + in[i] modulo 2^32. threads == 1: std::inclusive_scan;
// otherwise per-chunk std::reduce, a serial scan of the chunk sums, then a
// per-chunk std::inclusive_scan seeded with the chunk's carry.
void cpu_inclusive_scan(const std::vector<uint32_t>& in, std::vector<uint32_t>& out, unsigned threads);

// Stable sort by key: std::stable_sort per chunk, then stable std::inplace_merge.
template <class K>
void cpu_stable_sort_by_key(std::vector<KeyValue<K>>& v, unsigned threads);

// std::sort by (key, value): equals the stable order when values are the
// original indices, which is how icube-bench fills them.
template <class K>
void cpu_sort_by_key_value(std::vector<KeyValue<K>>& v, unsigned threads);

// Human-readable names for the result table.
std::string cpu_scan_name(unsigned threads);
std::string cpu_stable_sort_name(unsigned threads);
std::string cpu_sort_name(unsigned threads);

extern template void cpu_stable_sort_by_key<uint32_t>(std::vector<KeyValue<uint32_t>>&, unsigned);
extern template void cpu_stable_sort_by_key<uint64_t>(std::vector<KeyValue<uint64_t>>&, unsigned);
extern template void cpu_sort_by_key_value<uint32_t>(std::vector<KeyValue<uint32_t>>&, unsigned);
extern template void cpu_sort_by_key_value<uint64_t>(std::vector<KeyValue<uint64_t>>&, unsigned);

}  // namespace icube::bench
