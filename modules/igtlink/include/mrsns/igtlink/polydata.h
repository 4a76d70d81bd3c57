#pragma once
// POLYDATA content: points, four cell arrays (VTK style) and attributes.
#include <Eigen/Core>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

/// Cells as offsets into one index array: cell c holds
/// indices[offsets[c] .. offsets[c+1]). Empty offsets means no cells;
/// otherwise offsets[0] == 0 and offsets.back() == indices.size().
struct CellArray {
  std::vector<std::uint32_t> offsets;
  std::vector<std::uint32_t> indices;

  [[nodiscard]] std::size_t size() const { return offsets.empty() ? 0 : offsets.size() - 1; }
  [[nodiscard]] bool empty() const { return size() == 0; }
  [[nodiscard]] std::span<const std::uint32_t> cell(std::size_t c) const {
    return std::span<const std::uint32_t>(indices).subspan(offsets[c], offsets[c + 1] - offsets[c]);
  }
  void add(std::span<const std::uint32_t> cell_indices);
  void add(std::initializer_list<std::uint32_t> cell_indices) {
    add(std::span<const std::uint32_t>(cell_indices.begin(), cell_indices.size()));
  }
  /// Bytes on the wire: one count word plus the indices per cell, 4 bytes each.
  [[nodiscard]] std::uint64_t wireBytes() const { return 4 * (static_cast<std::uint64_t>(size()) + indices.size()); }
};

enum class AttributeKind : std::uint8_t { kScalar = 0, kVector = 1, kNormal = 2, kTensor = 3, kRgba = 4 };

/// One data set attribute: `data` has one row per point (or cell, when
/// cell_data) and one column per component (vectors/normals 3, tensors 9,
/// RGBA 4 in [0, 1], scalars 1 or more). Names are at most 255 characters.
struct PolyDataAttribute {
  AttributeKind kind = AttributeKind::kScalar;
  bool cell_data = false;
  std::string name;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> data;
};

struct PolyDataContent {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> points;
  CellArray vertices;
  CellArray lines;
  CellArray polygons;
  CellArray triangle_strips;
  std::vector<PolyDataAttribute> attributes;
};

inline constexpr std::size_t kPolyDataHeaderSize = 40;
inline constexpr std::size_t kMaxAttributeNameLength = 255;

/// Throws InvalidArgumentError for inconsistent content (bad offsets, indices
/// beyond the points, wrong component counts, names too long).
void encodePolyData(const PolyDataContent& content, std::vector<std::uint8_t>& out);
/// Throws FormatError for sizes that disagree with the data, counts that
/// overflow, indices beyond the point count or malformed attributes.
PolyDataContent decodePolyData(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
