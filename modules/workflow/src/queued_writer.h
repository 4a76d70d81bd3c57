#pragma once
// A bounded queue drained by its own thread: what lets a real-time producer
// (the tracking source, the navigation loop) hand a frame to the disk without
// ever waiting for it. The recorders of a navigation run (tracking, video)
// differ only in what they write and in what a full queue gives up.
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>

namespace mrsns::workflow::detail {

enum class WhenFull {
  DropOldest,  ///< keep the newest (a live view: the video)
  DropNewest,  ///< keep a contiguous record up to the stall (the tracking)
};

enum class Pushed {
  Queued,
  Dropped,  ///< the queue was full: this item or the oldest was given up
  Stopped,  ///< the writer has stopped: nothing queued
};

template <class T>
class QueuedWriter {
 public:
  /// `write` runs on the writer's thread for every item, in order; `finish` once after the last one.
  QueuedWriter(std::size_t max_queued, WhenFull when_full, std::function<void(T&)> write,
               std::function<void()> finish = {})
      : max_queued_(max_queued == 0 ? 1 : max_queued),
        when_full_(when_full),
        write_(std::move(write)),
        finish_(std::move(finish)) {
    thread_ = std::thread([this] { run(); });
  }
  ~QueuedWriter() { stop(); }
  QueuedWriter(const QueuedWriter&) = delete;
  QueuedWriter& operator=(const QueuedWriter&) = delete;

  /// Queues an item. Never waits for the writer. May throw std::bad_alloc (the caller counts the item as
  /// dropped).
  Pushed push(T item) {
    Pushed result = Pushed::Queued;
    {
      std::lock_guard lock(mutex_);
      if (stopping_) return Pushed::Stopped;
      if (queue_.size() >= max_queued_) {
        if (when_full_ == WhenFull::DropNewest) return Pushed::Dropped;
        queue_.pop_front();
        result = Pushed::Dropped;
      }
      queue_.push_back(std::move(item));
    }
    wake_.notify_one();
    return result;
  }

  /// Writes everything queued, runs `finish`, ends the thread. Idempotent.
  void stop() noexcept {
    {
      std::lock_guard lock(mutex_);
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void run() {
    while (true) {
      T item;
      {
        std::unique_lock lock(mutex_);
        wake_.wait(lock, [this] { return !queue_.empty() || stopping_; });
        if (queue_.empty()) break;  // stopping, and everything queued is written
        item = std::move(queue_.front());
        queue_.pop_front();
      }
      write_(item);
    }
    if (finish_) finish_();
  }

  std::size_t max_queued_;
  WhenFull when_full_;
  std::function<void(T&)> write_;
  std::function<void()> finish_;
  std::mutex mutex_;  // guards queue_, stopping_
  std::condition_variable wake_;
  std::deque<T> queue_;
  bool stopping_ = false;
  std::thread thread_;  // last: started once everything above exists
};

}  // namespace mrsns::workflow::detail
