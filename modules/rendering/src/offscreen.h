#pragma once
// Offscreen rendering of renderers into a PNG (private to rendering).
#include <array>
#include <filesystem>
#include <vector>

class vtkRenderer;
class vtkRenderWindow;

namespace mrsns::rendering::detail {

struct ViewportRenderer {
  vtkRenderer* renderer = nullptr;
  std::array<double, 4> viewport{0.0, 0.0, 1.0, 1.0};  ///< xmin, ymin, xmax, ymax in [0, 1]
};

/// Renders the renderers offscreen at width x height and writes an RGB PNG.
/// A renderer already shown in a window (the GUI's) is borrowed and given
/// back afterwards. Throws InvalidArgumentError for a size outside
/// [16, 8192], UnsupportedError without a display, FileError when writing fails.
/// The process's one offscreen render window (created on first use). Use
/// it from one thread, one client at a time.
vtkRenderWindow* sharedOffscreenWindow();

/// Throws InvalidArgumentError for a size outside [16, 8192] and
/// UnsupportedError without an X display.
void checkOffscreen(int width, int height);

/// Grabs the window's back buffer into an RGB PNG. Throws FileError.
void writeWindowPng(vtkRenderWindow* window, const std::filesystem::path& png);

void renderToPng(const std::vector<ViewportRenderer>& renderers, const std::filesystem::path& png, int width,
                 int height);

}  // namespace mrsns::rendering::detail
