#pragma once
// An offscreen window kept open on a scene, for many frames in a row
// (benchmarks, frame sequences in trial reports); snapshotPng() opens one per
// call instead.
#include <filesystem>
#include <memory>

namespace mrsns::rendering {

class Scene;

class OffscreenView {
 public:
  /// Borrows scene.renderer() until destruction (the scene must outlive the
  /// view). Views and snapshots share the process's one offscreen window:
  /// keep one view at a time and take no snapshot while it exists. Throws
  /// like snapshotPng for a bad size or a missing display.
  OffscreenView(Scene& scene, int width, int height);
  ~OffscreenView();
  OffscreenView(const OffscreenView&) = delete;
  OffscreenView& operator=(const OffscreenView&) = delete;

  /// Renders one frame and waits until the GPU (or Mesa) has finished it.
  /// Returns the frame's wall-clock time in seconds.
  double render();
  /// Writes the last rendered frame as an RGB PNG. Throws FileError.
  void writePng(const std::filesystem::path& png);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns::rendering
