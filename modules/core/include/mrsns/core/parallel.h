#pragma once
// A minimal fork-join loop for the few hot paths that are embarrassingly
// parallel (ICP correspondences, frame splatting): the index range is cut into
// one contiguous block per thread, the calling thread runs the first block,
// and the first exception thrown by any block is rethrown after all joined.
// Results must not depend on the thread count: callers write per-index
// outputs and reduce them afterwards in index order.
#include <algorithm>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace mrsns {

/// Threads a parallel loop uses by default: the hardware's, at least 1.
inline unsigned defaultThreadCount() {
  return std::max(1u, std::thread::hardware_concurrency());
}

/// Calls fn(begin_i, end_i) on disjoint blocks covering [begin, end), one per
/// thread (at most `threads`, 0 = defaultThreadCount(), and no block smaller
/// than `min_block`). Blocks run concurrently: fn must only write state owned
/// by its block.
template <typename Fn>
void parallelForBlocks(std::size_t begin, std::size_t end, Fn&& fn, unsigned threads = 0,
                       std::size_t min_block = 1) {
  if (end <= begin) return;
  const std::size_t n = end - begin;
  std::size_t t = threads == 0 ? defaultThreadCount() : threads;
  t = std::max<std::size_t>(1, std::min(t, n / std::max<std::size_t>(min_block, 1)));
  if (t <= 1) {
    fn(begin, end);
    return;
  }
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto run = [&](std::size_t b, std::size_t e) {
    try {
      fn(b, e);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
  };
  std::vector<std::thread> workers;
  workers.reserve(t - 1);
  for (std::size_t k = 1; k < t; ++k) workers.emplace_back(run, begin + n * k / t, begin + n * (k + 1) / t);
  run(begin, begin + n / t);
  for (auto& w : workers) w.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace mrsns
