#include "mrsns/rendering/scene.h"
#include "offscreen.h"

namespace mrsns::rendering {

void snapshotPng(Scene& scene, const std::filesystem::path& png, int width, int height) {
  detail::renderToPng({{scene.renderer(), {0.0, 0.0, 1.0, 1.0}}}, png, width, height);
}

}  // namespace mrsns::rendering
