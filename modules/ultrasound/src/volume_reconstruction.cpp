#include "mrsns/ultrasound/volume_reconstruction.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/parallel.h"

namespace mrsns::ultrasound {

ImageVolume gridAroundCorners(const std::vector<Eigen::Vector3d>& corners_mm, double spacing_mm, double margin_mm,
                              std::size_t max_voxels) {
  if (!(spacing_mm > 0.0) || !std::isfinite(spacing_mm)) {
    throw InvalidArgumentError("volume spacing must be positive, got " + formatGeneral(spacing_mm) + " mm");
  }
  if (corners_mm.empty()) throw InvalidArgumentError("no frame to place: the volume needs at least one frame");
  Eigen::Vector3d lo = corners_mm.front(), hi = corners_mm.front();
  for (const auto& c : corners_mm) {
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  lo.array() -= margin_mm;
  hi.array() += margin_mm;
  ImageVolume grid;
  grid.spacing = Eigen::Vector3d::Constant(spacing_mm);
  grid.origin = lo;
  std::size_t voxels = 1;
  for (int a = 0; a < 3; ++a) {
    grid.size[static_cast<std::size_t>(a)] = static_cast<int>(std::ceil((hi[a] - lo[a]) / spacing_mm)) + 1;
    voxels *= static_cast<std::size_t>(grid.size[static_cast<std::size_t>(a)]);
  }
  if (voxels > max_voxels) {
    const double suggested = spacing_mm * std::cbrt(static_cast<double>(voxels) / static_cast<double>(max_voxels));
    throw InvalidArgumentError("a volume of " + std::to_string(grid.size[0]) + " x " + std::to_string(grid.size[1]) +
                               " x " + std::to_string(grid.size[2]) +
                               " voxels is too large; use a spacing of at least " + formatGeneral(suggested) + " mm");
  }
  grid.pixel_type = PixelType::UInt8;
  return grid;
}

VolumeReconstructor::VolumeReconstructor(const ImageVolume& grid, unsigned threads) : grid_(grid), threads_(threads) {
  if (grid_.voxelCount() == 0) throw InvalidArgumentError("the reconstruction grid has no voxels");
  grid_.data.clear();
  accumulator_.assign(grid_.voxelCount(), Accumulated{});
}

namespace {

struct SplatCounts {
  std::size_t inside = 0, outside = 0;
};

}  // namespace

void VolumeReconstructor::addFrame(const GrayImageView& frame, const Eigen::Matrix4d& grid_T_image,
                                   std::array<int, 4> clip) {
  if (frame.width <= 0 || frame.height <= 0 ||
      frame.pixels.size() != static_cast<std::size_t>(frame.width) * static_cast<std::size_t>(frame.height)) {
    throw InvalidArgumentError("a frame of " + std::to_string(frame.width) + " x " + std::to_string(frame.height) +
                               " pixels holds " + std::to_string(frame.pixels.size()) + " values");
  }
  if (!grid_T_image.allFinite()) throw InvalidArgumentError("the frame's grid_T_image holds NaN or infinite values");
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
  const std::size_t sx = 1, sy = static_cast<std::size_t>(nx), sz = sy * static_cast<std::size_t>(ny);
  const std::array<std::size_t, 8> offset = {0, sx, sy, sx + sy, sz, sx + sz, sy + sz, sx + sy + sz};
  Accumulated* const acc = accumulator_.data();

  auto splatRows = [&](int ya, int yb, SplatCounts& counts) {
    for (int y = ya; y < yb; ++y) {
      const Eigen::Vector3d row = o + dv * y;
      const std::uint8_t* pixels = frame.pixels.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(frame.width);
      for (int x = x0; x < x1; ++x) {
        const Eigen::Vector3d p = row + du * x;
        const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
        const int i = static_cast<int>(fx), j = static_cast<int>(fy), k = static_cast<int>(fz);
        if (i < 0 || j < 0 || k < 0 || i + 1 >= nx || j + 1 >= ny || k + 1 >= nz) {
          ++counts.outside;
          continue;
        }
        ++counts.inside;
        const float value = pixels[x];
        const double ax = p.x() - fx, ay = p.y() - fy, az = p.z() - fz;
        // The trilinear weights, each the product (x * y) * z in double as a
        // straightforward splat computes it, so every contribution is the same.
        const double wx[2] = {1 - ax, ax}, wy[2] = {1 - ay, ay}, wz[2] = {1 - az, az};
        const std::size_t base = static_cast<std::size_t>(i) + sy * static_cast<std::size_t>(j) +
                                 sz * static_cast<std::size_t>(k);
        for (int c = 0; c < 8; ++c) {
          const auto w = static_cast<float>(wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1]);
          Accumulated& a = acc[base + offset[static_cast<std::size_t>(c)]];
          a.sum += w * value;
          a.weight += w;
        }
      }
    }
  };

  // Rows are splatted in bands processed in two phases, even bands then odd
  // ones, each phase in parallel. A band is tall enough that the rows of
  // bands i and i + 2 lie more than 2 sqrt(3) voxels apart (the distance
  // between two rows' lines is |dv| sin(angle(du, dv)) per row), so no two
  // bands of a phase touch one voxel. The order of the contributions to a
  // voxel is fixed by the bands, not by the thread count: the same bits on
  // any machine.
  const double du2 = du.squaredNorm();
  const Eigen::Vector3d dv_across = du2 > 0.0 ? Eigen::Vector3d(dv - du * (du.dot(dv) / du2)) : dv;
  const double row_gap = dv_across.norm();
  const int rows = std::max(0, y1 - y0);
  int band = rows;
  if (row_gap > 0.0 && std::isfinite(row_gap) && du2 > 0.0) {
    band = static_cast<int>(std::min<double>(rows, std::ceil(2.0 * std::sqrt(3.0) / row_gap) + 1.0));
  }
  band = std::max(band, 1);
  const int bands = rows > 0 ? (rows + band - 1) / band : 0;
  std::vector<SplatCounts> counts(static_cast<std::size_t>(bands));
  for (int phase = 0; phase < 2; ++phase) {
    const auto in_phase = static_cast<std::size_t>(bands > phase ? (bands - phase + 1) / 2 : 0);
    parallelForBlocks(
        0, in_phase,
        [&](std::size_t first, std::size_t last) {
          for (std::size_t n = first; n < last; ++n) {
            const int b = 2 * static_cast<int>(n) + phase;
            splatRows(y0 + b * band, std::min(y1, y0 + (b + 1) * band), counts[static_cast<std::size_t>(b)]);
          }
        },
        threads_);
  }
  for (const auto& c : counts) {
    figures_.pixels_inside += c.inside;
    figures_.pixels_outside += c.outside;
  }
  ++figures_.frames;
}

ImageVolume VolumeReconstructor::result(int hole_radius_voxels) {
  // A voxel counts as reached when at least a tenth of a pixel's weight
  // landed in it; fainter ones are edge effects of the trilinear splat.
  constexpr float kMinWeight = 0.1f;
  ImageVolume out = grid_;
  out.pixel_type = PixelType::UInt8;
  out.data.assign(out.voxelCount(), std::byte{0});
  std::vector<float> value(out.voxelCount(), 0.0f);
  std::vector<unsigned char> known(out.voxelCount(), 0);
  for (std::size_t n = 0; n < value.size(); ++n) {
    if (accumulator_[n].weight >= kMinWeight) {
      value[n] = accumulator_[n].sum / accumulator_[n].weight;
      known[n] = 1;
    }
  }
  const int r = std::max(0, hole_radius_voxels);
  // Each voxel of the output depends only on the inputs above: slices in parallel.
  std::vector<std::size_t> filled(static_cast<std::size_t>(out.size[2]), 0), reached(filled.size(), 0);
  parallelForBlocks(
      0, static_cast<std::size_t>(out.size[2]),
      [&](std::size_t k_first, std::size_t k_last) {
        for (auto kk = k_first; kk < k_last; ++kk) {
          const int k = static_cast<int>(kk);
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
                      s += value[m] * accumulator_[m].weight;
                      w += accumulator_[m].weight;
                    }
                  }
                }
                if (w > 0.0) {
                  v = static_cast<float>(s / w);
                  ++filled[kk];
                } else {
                  continue;
                }
              } else if (!known[n]) {
                continue;
              }
              ++reached[kk];
              out.data[n] = static_cast<std::byte>(static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L)));
            }
          }
        }
      },
      threads_);
  std::size_t filled_count = 0, known_count = 0;
  for (std::size_t k = 0; k < filled.size(); ++k) {
    filled_count += filled[k];
    known_count += reached[k];
  }
  figures_.holes_filled = filled_count;
  figures_.filled_fraction = static_cast<double>(known_count) / static_cast<double>(out.voxelCount());
  return out;
}

std::vector<float> sampleVolumeOnFrame(const ImageVolume& volume, const Eigen::Matrix4d& volume_T_image, int width,
                                       int height, float outside) {
  if (width <= 0 || height <= 0) throw InvalidArgumentError("frame size must be positive");
  if (volume.empty() || volume.data.size() != volume.byteCount()) {
    throw InvalidArgumentError("the volume to sample has no voxel data");
  }
  Eigen::Matrix4d index_T_lps = Eigen::Matrix4d::Identity();
  index_T_lps.topLeftCorner<3, 3>() = (volume.direction * volume.spacing.asDiagonal()).inverse();
  index_T_lps.topRightCorner<3, 1>() = -index_T_lps.topLeftCorner<3, 3>() * volume.origin;
  const Eigen::Matrix4d index_T_image = index_T_lps * volume_T_image;
  std::vector<float> out(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), outside);
  const int nx = volume.size[0], ny = volume.size[1], nz = volume.size[2];
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d p = (index_T_image * Eigen::Vector4d(x, y, 0.0, 1.0)).head<3>();
      // Voxel centres sit at integer indices; allow the half voxel around the
      // outermost ones by clamping the interpolation cell.
      if (p.x() < -0.5 || p.y() < -0.5 || p.z() < -0.5 || p.x() > nx - 0.5 || p.y() > ny - 0.5 || p.z() > nz - 0.5) {
        continue;
      }
      const auto cell = [](double c, int n, int& i0, double& a) {
        const double cc = std::clamp(c, 0.0, static_cast<double>(n - 1));
        i0 = std::min(static_cast<int>(std::floor(cc)), std::max(n - 2, 0));
        a = n > 1 ? cc - i0 : 0.0;
      };
      int i = 0, j = 0, k = 0;
      double ax = 0, ay = 0, az = 0;
      cell(p.x(), nx, i, ax);
      cell(p.y(), ny, j, ay);
      cell(p.z(), nz, k, az);
      double v = 0.0;
      for (int c = 0; c < 8; ++c) {
        const int ci = c & 1, cj = (c >> 1) & 1, ck = (c >> 2) & 1;
        const double w = (ci ? ax : 1 - ax) * (cj ? ay : 1 - ay) * (ck ? az : 1 - az);
        if (w == 0.0) continue;
        v += w * volume.value(std::min(i + ci, nx - 1), std::min(j + cj, ny - 1), std::min(k + ck, nz - 1));
      }
      out[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)] =
          static_cast<float>(v);
    }
  }
  return out;
}

}  // namespace mrsns::ultrasound
