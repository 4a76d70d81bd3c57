#include "mrsns/rendering/offscreen_view.h"

#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>

#include <chrono>

#include "mrsns/rendering/scene.h"
#include "offscreen.h"

namespace mrsns::rendering {

struct OffscreenView::Impl {
  vtkRenderWindow* window = nullptr;
  vtkRenderer* renderer = nullptr;
  vtkRenderWindow* owner = nullptr;
};

OffscreenView::OffscreenView(Scene& scene, int width, int height) : impl_(std::make_unique<Impl>()) {
  detail::checkOffscreen(width, height);
  impl_->renderer = scene.renderer();
  impl_->owner = impl_->renderer->GetRenderWindow();
  if (impl_->owner) impl_->owner->RemoveRenderer(impl_->renderer);
  impl_->window = detail::sharedOffscreenWindow();
  impl_->window->SetSize(width, height);
  impl_->window->AddRenderer(impl_->renderer);
}

OffscreenView::~OffscreenView() {
  impl_->window->RemoveRenderer(impl_->renderer);
  if (impl_->owner) impl_->owner->AddRenderer(impl_->renderer);
}

double OffscreenView::render() {
  const auto start = std::chrono::steady_clock::now();
  impl_->renderer->ResetCameraClippingRange();
  impl_->window->Render();
  impl_->window->WaitForCompletion();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void OffscreenView::writePng(const std::filesystem::path& png) {
  detail::writeWindowPng(impl_->window, png);
}

}  // namespace mrsns::rendering
