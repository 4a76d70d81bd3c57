#pragma once
// A clinical-size CT case made from the real CT of the shared data: the
// TotalSegmentator example CT (122 x 101 x 112 voxels of 3 mm) resampled
// trilinearly onto 512 x 512 x 400 voxels over the same field of view
// (about 0.71 x 0.59 x 0.84 mm), and a label map of 10 structures on that
// grid by nearest neighbour: the seven vertebrae S1-T12 of the spine report's
// label map, and the aorta, inferior vena cava and spinal cord of the organ
// label map (its crop placed on the CT by MR-SNS's own import-label-map with
// align_to, as a user would). Written as NIfTI (.nii.gz, the form a user's CT
// and TotalSegmentator's output arrive in) once per machine into the temp
// folder and reused while its files are whole.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>

#include "mrsns/core/data_dir.h"
#include "mrsns/core/image.h"
#include "mrsns/core/parallel.h"
#include "mrsns/io/image_io.h"
#include "mrsns/workflow/session.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::bench {

struct LargeCtCase {
  std::filesystem::path ct;      ///< 512 x 512 x 400 int16 HU, .nii.gz
  std::filesystem::path labels;  ///< the 10 labels on the same grid, uint8, .nii.gz
};

inline constexpr int kLargeCtSize[3] = {512, 512, 400};
/// The labels of the case (TotalSegmentator's values): vertebrae S1..T12, aorta, IVC, spinal cord.
inline constexpr int kLargeCtLabels[10] = {26, 27, 28, 29, 30, 31, 32, 52, 63, 79};

namespace detail {

inline ImageVolume resampledGrid(const ImageVolume& source, PixelType type) {
  ImageVolume out;
  out.size = {kLargeCtSize[0], kLargeCtSize[1], kLargeCtSize[2]};
  out.direction = source.direction;
  out.pixel_type = type;
  out.frame = source.frame;
  // The same field of view (voxel edges to voxel edges) on the finer grid.
  for (int a = 0; a < 3; ++a) {
    const double extent = source.size[a] * source.spacing[a];
    out.spacing[a] = extent / out.size[a];
  }
  const Eigen::Vector3d first_edge = source.indexToPhysical(Eigen::Vector3d::Constant(-0.5));
  out.origin = first_edge + source.direction * (0.5 * out.spacing);
  out.data.resize(out.byteCount());
  return out;
}

inline double sourceValue(const ImageVolume& image, int i, int j, int k) {
  i = std::clamp(i, 0, image.size[0] - 1);
  j = std::clamp(j, 0, image.size[1] - 1);
  k = std::clamp(k, 0, image.size[2] - 1);
  return image.value(i, j, k);
}

/// `source` resampled onto `grid` (trilinear, or nearest neighbour for labels), written into grid.data.
template <typename T>
void resampleInto(const ImageVolume& source, ImageVolume& grid, bool nearest) {
  const Eigen::Matrix4d to_source = source.ijkToLps().inverse() * grid.ijkToLps();
  T* out = reinterpret_cast<T*>(grid.data.data());
  parallelForBlocks(0, static_cast<std::size_t>(grid.size[2]), [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k) {
      for (int j = 0; j < grid.size[1]; ++j) {
        for (int i = 0; i < grid.size[0]; ++i) {
          const Eigen::Vector4d s = to_source * Eigen::Vector4d(i, j, static_cast<double>(k), 1.0);
          double v = 0.0;
          if (nearest) {
            v = sourceValue(source, static_cast<int>(std::lround(s.x())), static_cast<int>(std::lround(s.y())),
                            static_cast<int>(std::lround(s.z())));
          } else {
            const int x0 = static_cast<int>(std::floor(s.x())), y0 = static_cast<int>(std::floor(s.y())),
                      z0 = static_cast<int>(std::floor(s.z()));
            const double fx = s.x() - x0, fy = s.y() - y0, fz = s.z() - z0;
            for (int c = 0; c < 8; ++c) {
              const int dx = c & 1, dy = (c >> 1) & 1, dz = (c >> 2) & 1;
              const double w = (dx ? fx : 1.0 - fx) * (dy ? fy : 1.0 - fy) * (dz ? fz : 1.0 - fz);
              v += w * sourceValue(source, x0 + dx, y0 + dy, z0 + dz);
            }
          }
          out[grid.linearIndex(i, j, static_cast<int>(k))] = static_cast<T>(std::lround(v));
        }
      }
    }
  });
}

inline bool readable(const std::filesystem::path& p) {
  try {
    const auto info = io::readImageFile(p);
    return info.image.size[0] == kLargeCtSize[0] && info.image.size[1] == kLargeCtSize[1] &&
           info.image.size[2] == kLargeCtSize[2];
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace detail

/// The case's files, made on first use (tens of seconds: resampling and compressing 200 MB); nullopt with
/// `why` set when the shared data is missing.
inline std::optional<LargeCtCase> largeCtCase(std::string& why) {
  const auto data = findDataFile("ct/totalsegmentator/example_ct.nii.gz");
  const auto vertebrae = findDataFile("ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  const auto organs = findDataFile("ct/totalsegmentator/example_seg.nii.gz");
  if (!data || !vertebrae || !organs) {
    why = "the TotalSegmentator example CT and its label maps are not in the data directory (MRSNS_DATA_DIR)";
    return std::nullopt;
  }
  const auto dir = std::filesystem::temp_directory_path() / "mrsns-bench-ct512";
  LargeCtCase c{dir / "ct512.nii.gz", dir / "labels512.nii.gz"};
  static bool checked = false;
  if (checked || (std::filesystem::exists(c.ct) && std::filesystem::exists(c.labels) && detail::readable(c.ct) &&
                  detail::readable(c.labels))) {
    checked = true;
    return c;
  }
  std::filesystem::create_directories(dir);
  // The organ map's crop placed on the CT as import-label-map places it, in a scratch session.
  const auto scratch = dir / ("prepare-" + std::to_string(::getpid()));
  std::filesystem::remove_all(scratch);
  auto s = workflow::Session::create(scratch);
  const workflow::StepContext quiet;
  bool ok = workflow::runStep(s, "import-ct", {{"path", data->string()}}, quiet).ok &&
            workflow::runStep(s, "import-label-map", {{"path", vertebrae->string()}}, quiet).ok &&
            workflow::runStep(s, "import-label-map", {{"path", organs->string()}, {"align_to", "labels"}}, quiet).ok;
  if (!ok) {
    why = "the real CT did not import in a scratch session (see the log)";
    return std::nullopt;
  }
  const ImageVolume ct = io::readImage(s.resolve(s.ct()->file));
  const ImageVolume spine = io::readImage(s.resolve(s.labelMap("labels")->file));
  const ImageVolume organ_map = io::readImage(s.resolve(s.labelMap("labels-2")->file));
  // The 10 structures in one uint8 map on the CT's grid: the spine's vertebrae, then the vessels and cord.
  ImageVolume merged = spine;
  merged.pixel_type = PixelType::UInt8;
  merged.data.assign(merged.voxelCount(), std::byte{0});
  for (std::size_t v = 0; v < merged.voxelCount(); ++v) {
    const int vertebra = static_cast<int>(spine.valueAtIndex(v));
    const int organ = static_cast<int>(organ_map.valueAtIndex(v));
    int value = 0;
    if (vertebra >= 26 && vertebra <= 32) value = vertebra;
    if (value == 0 && (organ == 52 || organ == 63 || organ == 79)) value = organ;
    merged.data[v] = static_cast<std::byte>(value);
  }
  ImageVolume big_ct = detail::resampledGrid(ct, PixelType::Int16);
  detail::resampleInto<std::int16_t>(ct, big_ct, false);
  ImageVolume big_labels = detail::resampledGrid(merged, PixelType::UInt8);
  detail::resampleInto<std::uint8_t>(merged, big_labels, true);
  io::writeImage(big_ct, c.ct);
  io::writeImage(big_labels, c.labels);
  std::filesystem::remove_all(scratch);
  checked = true;
  return c;
}

}  // namespace mrsns::bench
