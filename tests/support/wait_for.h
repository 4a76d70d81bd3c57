#pragma once
// Waiting with a deadline in tests that drive threads and sockets.
#include <chrono>
#include <functional>
#include <thread>

namespace mrsns::test {

/// Polls `done` every `poll` until it holds or `deadline` passes; the last
/// answer of `done`.
inline bool waitFor(const std::function<bool()>& done, std::chrono::milliseconds deadline,
                    std::chrono::milliseconds poll = std::chrono::milliseconds(5)) {
  const auto end = std::chrono::steady_clock::now() + deadline;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(poll);
  }
  return done();
}

}  // namespace mrsns::test
