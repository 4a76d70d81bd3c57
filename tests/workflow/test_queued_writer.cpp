// The recorders' writer thread: everything queued is written, in order, when
// it stops; a full queue gives up the newest (tracking: a contiguous record up
// to a stall) or the oldest (video: the latest view), and says so.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <vector>

#include "queued_writer.h"

namespace mrsns::workflow::detail {
namespace {

// A writer whose disk is stalled until `release` is set: the first item blocks the thread, the rest queue.
struct StalledDisk {
  std::promise<void> release;
  std::shared_future<void> released = release.get_future().share();
  std::atomic<bool> first_taken{false};
  std::vector<int> written;
};

std::vector<int> fillAndDrain(WhenFull policy) {
  StalledDisk disk;
  QueuedWriter<int> writer(
      3, policy,
      [&](int& v) {
        disk.first_taken = true;
        disk.released.wait();
        disk.written.push_back(v);
      });
  EXPECT_EQ(writer.push(0), Pushed::Queued);
  while (!disk.first_taken) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  for (int v = 1; v <= 3; ++v) EXPECT_EQ(writer.push(v), Pushed::Queued);  // the queue holds 3
  EXPECT_EQ(writer.push(4), Pushed::Dropped);
  EXPECT_EQ(writer.push(5), Pushed::Dropped);
  disk.release.set_value();
  writer.stop();
  EXPECT_EQ(writer.push(6), Pushed::Stopped);
  return disk.written;
}

TEST(QueuedWriter, AFullQueueGivesUpTheNewestOrTheOldestAndStopWritesTheRest) {
  EXPECT_EQ(fillAndDrain(WhenFull::DropNewest), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(fillAndDrain(WhenFull::DropOldest), (std::vector<int>{0, 3, 4, 5}));
}

TEST(QueuedWriter, FinishRunsOnceAfterTheLastItem) {
  std::vector<int> written;
  int finished = 0;
  std::size_t written_at_finish = 0;
  {
    QueuedWriter<int> writer(
        100, WhenFull::DropNewest, [&](int& v) { written.push_back(v); },
        [&] {
          ++finished;
          written_at_finish = written.size();
        });
    for (int v = 0; v < 50; ++v) writer.push(v);
  }  // destroyed: stops
  EXPECT_EQ(finished, 1);
  EXPECT_EQ(written_at_finish, 50u);
  for (int v = 0; v < 50; ++v) EXPECT_EQ(written[static_cast<std::size_t>(v)], v);
}

}  // namespace
}  // namespace mrsns::workflow::detail
