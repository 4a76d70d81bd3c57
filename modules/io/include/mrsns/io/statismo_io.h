#pragma once
// Statistical shape models in statismo's HDF5 format (format 0.9, as written
// by statismo and scalismo): /model/{mean, pcaBasis, pcaVariance,
// noiseVariance}, the mesh representer /representer/{points 3 x N, cells
// 3 x M} with attributes name, datasetType and version/{major,minor}Version,
// /modelinfo and /version/{majorVersion, minorVersion}.
#include <filesystem>
#include <string>

#include "mrsns/core/shape_model.h"

namespace mrsns::io {

/// What a statismo file says about itself besides the model.
struct StatismoFileInfo {
  int major_version = 0;
  int minor_version = 0;
  std::string representer_name;  ///< e.g. "itkStandardMeshRepresenter"
  std::string dataset_type;      ///< "POLYGON_MESH" for shape models
  std::string build_time;        ///< /modelinfo/build-time, may be empty
  /// True when the stored basis was not orthonormal (scalismo's low-rank
  /// Gaussian-process models) and was re-expressed with an orthonormal one
  /// carrying the same covariance.
  bool basis_orthonormalized = false;
};

/// Reads a shape model with a mesh representer. Format 0.8 files (scaled
/// basis) and non-orthonormal bases are converted to the 0.9 convention
/// (orthonormal basis, same mean and covariance). Throws
/// FileError when the file cannot be opened, FormatError naming the file and
/// dataset when it is not HDF5, lacks a statismo dataset or has inconsistent
/// sizes, and UnsupportedError for other representers (images, deformation
/// fields) or versions. `info` receives the header when given.
[[nodiscard]] ShapeModel readStatismoModel(const std::filesystem::path& path, StatismoFileInfo* info = nullptr);

struct StatismoWriteOptions {
  /// statismo and scalismo write and expect float32; Float64 keeps doubles
  /// bit-exact (statismo's reader converts, scalismo's may not).
  bool double_precision = false;
  std::string representer_name = "itkStandardMeshRepresenter";
  std::string builder_name = "mrsns::deformation::buildShapeModel";
};

/// Writes `model` in statismo format 0.9 with the layout above. Throws
/// InvalidArgumentError for an inconsistent model and FileError when the file
/// cannot be created.
void writeStatismoModel(const ShapeModel& model, const std::filesystem::path& path,
                        const StatismoWriteOptions& options = {});

}  // namespace mrsns::io
