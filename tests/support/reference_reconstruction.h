#pragma once
// The straightforward trilinear splat, one pixel after another on one
// thread, exactly as VolumeReconstructor was written before it was made
// parallel: the oracle its results are compared with (tests) and the peer its
// speed is compared with (benchmarks).
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/image.h"
#include "mrsns/ultrasound/volume_reconstruction.h"

namespace mrsns::test {

using ultrasound::GrayImageView;
using ultrasound::ReconstructionFigures;

class ReferenceReconstructor {
 public:
  explicit ReferenceReconstructor(const ImageVolume& grid);
  void addFrame(const GrayImageView& frame, const Eigen::Matrix4d& grid_T_image, std::array<int, 4> clip = {});
  [[nodiscard]] ImageVolume result(int hole_radius_voxels = 1);
  [[nodiscard]] const ReconstructionFigures& figures() const { return figures_; }

 private:
  ImageVolume grid_;
  std::vector<float> sum_, weight_;
  ReconstructionFigures figures_;
};

inline ReferenceReconstructor::ReferenceReconstructor(const ImageVolume& grid) : grid_(grid) {
  if (grid_.voxelCount() == 0) throw InvalidArgumentError("the reconstruction grid has no voxels");
  grid_.data.clear();
  sum_.assign(grid_.voxelCount(), 0.0f);
  weight_.assign(grid_.voxelCount(), 0.0f);
}

inline void ReferenceReconstructor::addFrame(const GrayImageView& frame, const Eigen::Matrix4d& grid_T_image,
                                             std::array<int, 4> clip) {
  if (frame.width <= 0 || frame.height <= 0 ||
      frame.pixels.size() != static_cast<std::size_t>(frame.width) * static_cast<std::size_t>(frame.height)) {
    throw InvalidArgumentError("a frame of " + std::to_string(frame.width) + " x " + std::to_string(frame.height) +
                               " pixels holds " + std::to_string(frame.pixels.size()) + " values");
  }
  if (clip[2] <= 0 || clip[3] <= 0) clip = {0, 0, frame.width, frame.height};
  const int x0 = std::clamp(clip[0], 0, frame.width), y0 = std::clamp(clip[1], 0, frame.height);
  const int x1 = std::clamp(clip[0] + clip[2], 0, frame.width), y1 = std::clamp(clip[1] + clip[3], 0, frame.height);
  // Pixel -> continuous voxel index, one affine map for the whole frame.
  Eigen::Matrix4d index_T_grid = Eigen::Matrix4d::Identity();
  index_T_grid.topLeftCorner<3, 3>() = (grid_.direction * grid_.spacing.asDiagonal()).inverse();
  index_T_grid.topRightCorner<3, 1>() = -index_T_grid.topLeftCorner<3, 3>() * grid_.origin;
  const Eigen::Matrix4d index_T_image = index_T_grid * grid_T_image;
  const Eigen::Vector3d du = index_T_image.block<3, 1>(0, 0), dv = index_T_image.block<3, 1>(0, 1);
  const Eigen::Vector3d o = index_T_image.block<3, 1>(0, 3);
  const int nx = grid_.size[0], ny = grid_.size[1], nz = grid_.size[2];
  for (int y = y0; y < y1; ++y) {
    const Eigen::Vector3d row = o + dv * y;
    for (int x = x0; x < x1; ++x) {
      const Eigen::Vector3d p = row + du * x;
      const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
      const int i = static_cast<int>(fx), j = static_cast<int>(fy), k = static_cast<int>(fz);
      if (i < 0 || j < 0 || k < 0 || i + 1 >= nx || j + 1 >= ny || k + 1 >= nz) {
        ++figures_.pixels_outside;
        continue;
      }
      ++figures_.pixels_inside;
      const float value = frame.pixels[static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.width) +
                                       static_cast<std::size_t>(x)];
      const double ax = p.x() - fx, ay = p.y() - fy, az = p.z() - fz;
      for (int c = 0; c < 8; ++c) {
        const int ci = c & 1, cj = (c >> 1) & 1, ck = (c >> 2) & 1;
        const auto w = static_cast<float>((ci ? ax : 1 - ax) * (cj ? ay : 1 - ay) * (ck ? az : 1 - az));
        const std::size_t idx = grid_.linearIndex(i + ci, j + cj, k + ck);
        sum_[idx] += w * value;
        weight_[idx] += w;
      }
    }
  }
  ++figures_.frames;
}

inline ImageVolume ReferenceReconstructor::result(int hole_radius_voxels) {
  // A voxel counts as reached when at least a tenth of a pixel's weight
  // landed in it; fainter ones are edge effects of the trilinear splat.
  constexpr float kMinWeight = 0.1f;
  ImageVolume out = grid_;
  out.pixel_type = PixelType::UInt8;
  out.data.assign(out.voxelCount(), std::byte{0});
  std::vector<float> value(out.voxelCount(), 0.0f);
  std::vector<unsigned char> known(out.voxelCount(), 0);
  for (std::size_t n = 0; n < value.size(); ++n) {
    if (weight_[n] >= kMinWeight) {
      value[n] = sum_[n] / weight_[n];
      known[n] = 1;
    }
  }
  std::size_t filled = 0, known_count = 0;
  const int r = std::max(0, hole_radius_voxels);
  for (int k = 0; k < out.size[2]; ++k) {
    for (int j = 0; j < out.size[1]; ++j) {
      for (int i = 0; i < out.size[0]; ++i) {
        const std::size_t n = out.linearIndex(i, j, k);
        float v = value[n];
        if (!known[n] && r > 0) {
          double s = 0.0, w = 0.0;
          for (int dk = -r; dk <= r; ++dk) {
            for (int dj = -r; dj <= r; ++dj) {
              for (int di = -r; di <= r; ++di) {
                const int a = i + di, b = j + dj, c = k + dk;
                if (a < 0 || b < 0 || c < 0 || a >= out.size[0] || b >= out.size[1] || c >= out.size[2]) continue;
                const std::size_t m = out.linearIndex(a, b, c);
                if (!known[m]) continue;
                s += value[m] * weight_[m];
                w += weight_[m];
              }
            }
          }
          if (w > 0.0) {
            v = static_cast<float>(s / w);
            ++filled;
          } else {
            continue;
          }
        } else if (!known[n]) {
          continue;
        }
        ++known_count;
        out.data[n] = static_cast<std::byte>(static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L)));
      }
    }
  }
  figures_.holes_filled = filled;
  figures_.filled_fraction = static_cast<double>(known_count) / static_cast<double>(out.voxelCount());
  return out;
}

}  // namespace mrsns::test
