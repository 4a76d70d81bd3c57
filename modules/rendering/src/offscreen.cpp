#include "offscreen.h"

#include <vtkPNGWriter.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkWindowToImageFilter.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::rendering::detail {

vtkRenderWindow* sharedOffscreenWindow() {
  // One offscreen window for the whole process: creating and destroying X
  // windows repeatedly makes VTK 9.1 on Xvfb/Mesa abort after a handful
  // ("bad X server connection"), and reusing the context is faster anyway.
  static vtkSmartPointer<vtkRenderWindow> window;
  if (!window) {
    window = vtkSmartPointer<vtkRenderWindow>::New();
    window->SetOffScreenRendering(1);
    // Multisampling costs ~2x per frame on llvmpipe for little visible gain.
    window->SetMultiSamples(0);
  }
  return window;
}

void checkOffscreen(int width, int height) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192) {
    throw InvalidArgumentError("snapshot size " + std::to_string(width) + "x" + std::to_string(height) +
                               ": width and height must lie in [16, 8192] pixels");
  }
  // VTK's X render window aborts the process without a display; say what to do instead.
  const char* display = std::getenv("DISPLAY");
  if (display == nullptr || *display == '\0') {
    throw UnsupportedError("offscreen rendering needs an X display (DISPLAY is not set): run under 'xvfb-run -a'");
  }
}

void writeWindowPng(vtkRenderWindow* window, const std::filesystem::path& png) {
  {
    // Fail with the path in the message; vtkPNGWriter only logs.
    std::ofstream probe(png, std::ios::binary | std::ios::app);
    if (!probe)
      throw FileError("cannot write snapshot '" + png.string() + "': check the folder exists and is writable");
  }
  auto grab = vtkSmartPointer<vtkWindowToImageFilter>::New();
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();
  auto writer = vtkSmartPointer<vtkPNGWriter>::New();
  writer->SetFileName(png.string().c_str());
  writer->SetInputConnection(grab->GetOutputPort());
  writer->Write();
  if (writer->GetErrorCode() != 0) {
    throw FileError("cannot write snapshot '" + png.string() + "': disk full or not writable");
  }
}

void renderToPng(const std::vector<ViewportRenderer>& renderers, const std::filesystem::path& png, int width,
                 int height) {
  checkOffscreen(width, height);
  {
    // Fail before rendering when the PNG cannot be created.
    std::ofstream probe(png, std::ios::binary | std::ios::app);
    if (!probe)
      throw FileError("cannot write snapshot '" + png.string() + "': check the folder exists and is writable");
  }

  vtkRenderWindow* window = sharedOffscreenWindow();
  window->SetSize(width, height);
  struct Borrowed {
    vtkRenderer* renderer;
    vtkRenderWindow* owner;
    std::array<double, 4> viewport;
  };
  std::vector<Borrowed> borrowed;
  for (const auto& r : renderers) {
    Borrowed b{r.renderer, r.renderer->GetRenderWindow(), {}};
    r.renderer->GetViewport(b.viewport.data());
    if (b.owner) b.owner->RemoveRenderer(r.renderer);
    r.renderer->SetViewport(r.viewport[0], r.viewport[1], r.viewport[2], r.viewport[3]);
    window->AddRenderer(r.renderer);
    borrowed.push_back(b);
  }
  auto giveBack = [&] {
    for (const auto& b : borrowed) {
      window->RemoveRenderer(b.renderer);
      b.renderer->SetViewport(b.viewport[0], b.viewport[1], b.viewport[2], b.viewport[3]);
      if (b.owner) b.owner->AddRenderer(b.renderer);
    }
  };
  try {
    for (const auto& r : renderers) r.renderer->ResetCameraClippingRange();
    window->Render();
    writeWindowPng(window, png);
  } catch (...) {
    giveBack();
    throw;
  }
  giveBack();
}

}  // namespace mrsns::rendering::detail
