// CPU scan and sort implementations icube-bench times against the GPU kernels
// (single-threaded std:: algorithms, or the same split over std::threads).
#include "bench_cpu.h"

#include <algorithm>
#include <functional>
#include <numeric>
#include <thread>

namespace icube::bench {

namespace {

// Boundaries of `chunks` nearly equal chunks of [0, n): chunk i is [b[i], b[i+1]).
std::vector<size_t> chunk_bounds(size_t n, unsigned chunks) {
  std::vector<size_t> b(chunks + 1);
  for (unsigned i = 0; i <= chunks; ++i) b[i] = n * i / chunks;
  return b;
}

// Runs task(i) for i in [0, count): task 0 on the calling thread, the others on new std::threads.
void run_parallel(unsigned count, const std::function<void(unsigned)>& task) {
  std::vector<std::thread> workers;
  workers.reserve(count > 0 ? count - 1 : 0);
  for (unsigned i = 1; i < count; ++i) workers.emplace_back(task, i);
  if (count > 0) task(0);
  for (std::thread& t : workers) t.join();
}

// Sorts every chunk with `sort_range`, then merges neighbouring chunks
// pairwise (in parallel within one level) with std::inplace_merge, which
// keeps equal elements of the left chunk first, so stable chunk sorts give a
// stable result.
template <class T, class SortRange, class Less>
void chunked_sort(std::vector<T>& v, unsigned threads, SortRange sort_range, Less less) {
  threads = std::max(1u, std::min<unsigned>(threads, static_cast<unsigned>(std::max<size_t>(v.size(), 1))));
  std::vector<size_t> bounds = chunk_bounds(v.size(), threads);
  run_parallel(threads, [&](unsigned i) { sort_range(v.begin() + bounds[i], v.begin() + bounds[i + 1]); });
  while (bounds.size() > 2) {
    const unsigned merges = static_cast<unsigned>((bounds.size() - 1) / 2);
    run_parallel(merges, [&](unsigned m) {
      std::inplace_merge(v.begin() + bounds[2 * m], v.begin() + bounds[2 * m + 1], v.begin() + bounds[2 * m + 2], less);
    });
    const size_t chunks = bounds.size() - 1;
    std::vector<size_t> next;
    for (size_t i = 0; i <= chunks; i += 2) next.push_back(bounds[i]);
    if (chunks % 2) next.push_back(bounds[chunks]);  // the odd chunk out moves up unmerged
    bounds.swap(next);
  }
}

template <class K>
bool key_less(const KeyValue<K>& a, const KeyValue<K>& b) {
  return a.key < b.key;
}

template <class K>
bool key_value_less(const KeyValue<K>& a, const KeyValue<K>& b) {
  return a.key != b.key ? a.key < b.key : a.value < b.value;
}

std::string thread_suffix(unsigned threads) {
  return threads == 1 ? ", 1 thread" : ", " + std::to_string(threads) + " threads";
}

}  // namespace

void cpu_inclusive_scan(const std::vector<uint32_t>& in, std::vector<uint32_t>& out, unsigned threads) {
  out.resize(in.size());
  if (threads <= 1 || in.size() < threads) {
    std::inclusive_scan(in.begin(), in.end(), out.begin());
    return;
  }
  const std::vector<size_t> b = chunk_bounds(in.size(), threads);
  std::vector<uint32_t> carry(threads, 0u);
  run_parallel(threads, [&](unsigned i) { carry[i] = std::reduce(in.begin() + b[i], in.begin() + b[i + 1], 0u); });
  std::exclusive_scan(carry.begin(), carry.end(), carry.begin(), 0u);
  run_parallel(threads, [&](unsigned i) {
    std::inclusive_scan(in.begin() + b[i], in.begin() + b[i + 1], out.begin() + b[i], std::plus<uint32_t>(), carry[i]);
  });
}

template <class K>
void cpu_stable_sort_by_key(std::vector<KeyValue<K>>& v, unsigned threads) {
  using It = typename std::vector<KeyValue<K>>::iterator;
  chunked_sort(
      v, threads, [](It first, It last) { std::stable_sort(first, last, key_less<K>); }, key_less<K>);
}

template <class K>
void cpu_sort_by_key_value(std::vector<KeyValue<K>>& v, unsigned threads) {
  using It = typename std::vector<KeyValue<K>>::iterator;
  chunked_sort(
      v, threads, [](It first, It last) { std::sort(first, last, key_value_less<K>); }, key_value_less<K>);
}

std::string cpu_scan_name(unsigned threads) {
  return (threads == 1 ? "cpu std::inclusive_scan" : "cpu chunked 2-pass scan") + thread_suffix(threads);
}

std::string cpu_stable_sort_name(unsigned threads) {
  return (threads == 1 ? "cpu std::stable_sort pairs" : "cpu std::stable_sort chunks + inplace_merge") +
         thread_suffix(threads);
}

std::string cpu_sort_name(unsigned threads) {
  return (threads == 1 ? "cpu std::sort pairs" : "cpu std::sort chunks + inplace_merge") + thread_suffix(threads);
}

template void cpu_stable_sort_by_key<uint32_t>(std::vector<KeyValue<uint32_t>>&, unsigned);
template void cpu_stable_sort_by_key<uint64_t>(std::vector<KeyValue<uint64_t>>&, unsigned);
template void cpu_sort_by_key_value<uint32_t>(std::vector<KeyValue<uint32_t>>&, unsigned);
template void cpu_sort_by_key_value<uint64_t>(std::vector<KeyValue<uint64_t>>&, unsigned);

}  // namespace icube::bench
