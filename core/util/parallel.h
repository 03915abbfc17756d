// ParallelFor(count, threads, fn): calls fn(i) for i in [0, count) on up to `threads` threads
// (0 = all cores), the calling thread included; returns when all calls have returned. Work is
// handed out one index at a time, so uneven costs balance. fn must be safe to call concurrently.
#pragma once

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace gb {

inline int HardwareThreads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n == 0 ? 1 : static_cast<int>(n);
}

template <class Fn>
void ParallelFor(int count, int threads, Fn&& fn) {
  if (threads <= 0) threads = HardwareThreads();
  threads = std::max(1, std::min(threads, count));
  if (threads == 1) {
    for (int i = 0; i < count; ++i) fn(i);
    return;
  }
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) fn(i);
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}

}  // namespace gb
