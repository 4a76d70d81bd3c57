// Crash-safe recording: a child process records a tracking stream and is
// killed with SIGKILL; the file reopens with every frame older than the sync
// interval (0.5 s here, so "at most the last second" holds with margin).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/io/sequence_appender.h"
#include "mrsns/io/sequence_file.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

double monotonicNow() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);  // shared by parent and child, unlike steady_clock's epoch guarantees
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

TrackedSequence imageLayout() {
  TrackedSequence layout;
  layout.geometry.size = {16, 8, 1};
  layout.geometry.spacing = {0.2, 0.2, 1.0};
  layout.pixel_format = FramePixelFormat{PixelType::UInt8, 1};
  return layout;
}

TrackedFrame frameNumber(std::size_t i, double t) {
  TrackedFrame f;
  f.timestamp = t;
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 3) = static_cast<double>(i);
  f.transforms["ProbeToTracker"] = FrameTransform{m, TransformStatus::Ok};
  f.custom_fields["FrameNumber"] = std::to_string(i);
  f.pixels.assign(16 * 8, static_cast<std::uint8_t>(i % 251));
  return f;
}

TEST(CrashSafeRecording, KillDashNineLosesAtMostTheSyncInterval) {
  const auto dir = test::scratchDirectory("rec");
  const auto path = dir / "tracking.mhd";
  constexpr double kSync = 0.5;
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // Child: record 200 frames/s until killed; nothing but the appender.
    try {
      SequenceAppender recorder(path, imageLayout(), SequenceAppenderOptions{kSync});
      for (std::size_t i = 0;; ++i) {
        recorder.append(frameNumber(i, monotonicNow()));
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    } catch (...) {
      _exit(3);
    }
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(2300));
  const double killed_at = monotonicNow();
  ASSERT_EQ(kill(child, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the recorder exited by itself (status " << status << ")";

  const auto sequence = readSequence(path);
  ASSERT_GT(sequence.frames.size(), 100u);
  // Every frame is intact, in order, none missing before the last one kept.
  for (std::size_t i = 0; i < sequence.frames.size(); ++i) {
    const auto& f = sequence.frames[i];
    ASSERT_EQ(f.custom_fields.at("FrameNumber"), std::to_string(i));
    ASSERT_EQ(f.transforms.at("ProbeToTracker").matrix(0, 3), static_cast<double>(i));
    ASSERT_EQ(f.pixels, std::vector<std::uint8_t>(16 * 8, static_cast<std::uint8_t>(i % 251))) << "frame " << i;
  }
  const double lost_s = killed_at - sequence.frames.back().timestamp;
  // The last sync happened at most kSync before the kill, plus one frame
  // period and scheduling slack on a loaded machine.
  EXPECT_LT(lost_s, 1.0) << "more than a second of recording lost";
  EXPECT_GE(lost_s, 0.0);
}

TEST(CrashSafeRecording, EmptyRecordingIsReadableAndSyncOnDestruction) {
  const auto dir = test::scratchDirectory("rec");
  {
    SequenceAppender recorder(dir / "a.mhd", SequenceAppender::trackerOnlyLayout(), SequenceAppenderOptions{10.0});
    EXPECT_EQ(readSequenceHeader(dir / "a.mhd").frames.size(), 0u);
    for (std::size_t i = 0; i < 5; ++i) {
      TrackedFrame f = frameNumber(i, static_cast<double>(i));
      f.pixels.clear();  // transform-only frame
      EXPECT_TRUE(recorder.append(f)) << recorder.lastError();
    }
    EXPECT_EQ(recorder.framesSynced(), 0u) << "synced before the interval";
  }
  const auto sequence = readSequence(dir / "a.mhd");
  ASSERT_EQ(sequence.frames.size(), 5u);
  EXPECT_EQ(sequence.frames[4].timestamp, 4.0);
}

TEST(CrashSafeRecording, RefusesToOverwriteAndBadFrames) {
  const auto dir = test::scratchDirectory("rec");
  { SequenceAppender first(dir / "a.mhd", imageLayout()); }
  EXPECT_THROW(SequenceAppender(dir / "a.mhd", imageLayout()), FileError);
  EXPECT_THROW(SequenceAppender(dir / "b.mha", imageLayout()), InvalidArgumentError);
  SequenceAppender recorder(dir / "c.mhd", imageLayout());
  TrackedFrame wrong = frameNumber(0, 0.0);
  wrong.pixels.resize(3);
  EXPECT_FALSE(recorder.append(wrong));
  EXPECT_NE(recorder.lastError().find("pixel bytes"), std::string::npos);
  EXPECT_TRUE(recorder.append(frameNumber(1, 1.0)));
}

}  // namespace
}  // namespace mrsns::io
