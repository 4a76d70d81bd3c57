#pragma once
// Reads a PNG written by the snapshots and answers colour questions by region.
#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <vtkSmartPointer.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <functional>

namespace mrsns::test {

struct PngImage {
  int width = 0;
  int height = 0;
  int components = 0;
  vtkSmartPointer<vtkImageData> data;

  /// Pixel (x, y) with y counted from the top, as in an image viewer.
  [[nodiscard]] std::array<int, 3> rgb(int x, int y) const {
    auto* p = static_cast<unsigned char*>(data->GetScalarPointer(x, height - 1 - y, 0));
    return {p[0], p[1], p[2]};
  }

  /// Pixels in [x0, x1) x [y0, y1) for which `test` holds.
  [[nodiscard]] int count(int x0, int y0, int x1, int y1, const std::function<bool(std::array<int, 3>)>& test) const {
    int n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) n += test(rgb(x, y)) ? 1 : 0;
    return n;
  }
};

inline PngImage readPng(const std::filesystem::path& path) {
  PngImage image;
  auto reader = vtkSmartPointer<vtkPNGReader>::New();
  reader->SetFileName(path.string().c_str());
  reader->Update();
  image.data = reader->GetOutput();
  int dims[3];
  image.data->GetDimensions(dims);
  image.width = dims[0];
  image.height = dims[1];
  image.components = image.data->GetNumberOfScalarComponents();
  return image;
}

// Colour classes with wide margins: lighting scales a surface's colour by
// its angle to the light, so only the dominant channel is reliable.
inline bool isReddish(std::array<int, 3> c) {
  return c[0] > 80 && c[0] > 2 * c[1] && c[0] > 2 * c[2];
}
inline bool isGreenish(std::array<int, 3> c) {
  return c[1] > 80 && c[1] > 2 * c[0] && c[1] > 2 * c[2];
}
inline bool isBluish(std::array<int, 3> c) {
  return c[2] > 80 && c[2] > 2 * c[0] && c[2] > 2 * c[1];
}
inline bool isBright(std::array<int, 3> c) {
  return c[0] > 180 && c[1] > 180 && c[2] > 180;
}
inline bool isDark(std::array<int, 3> c) {
  return c[0] < 40 && c[1] < 40 && c[2] < 40;
}

}  // namespace mrsns::test

/// Skips a test that renders when there is no X display (run under xvfb-run -a).
#define MRSNS_REQUIRE_DISPLAY()                                                          \
  do {                                                                                   \
    const char* display_ = std::getenv("DISPLAY");                                       \
    if (display_ == nullptr || *display_ == '\0') {                                      \
      GTEST_SKIP() << "no X display: run the rendering tests under 'xvfb-run -a ctest'"; \
    }                                                                                    \
  } while (false)
