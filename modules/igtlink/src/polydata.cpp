#include "mrsns/igtlink/polydata.h"

#include "mrsns/igtlink/byte_order.h"

namespace mrsns::igtlink {

void CellArray::add(std::span<const std::uint32_t> cell_indices) {
  if (offsets.empty()) offsets.push_back(0);
  indices.insert(indices.end(), cell_indices.begin(), cell_indices.end());
  offsets.push_back(static_cast<std::uint32_t>(indices.size()));
}

namespace {

constexpr std::uint8_t kCellDataBit = 0x10;

/// Components an attribute kind must have; 0 = any positive count (scalars).
int requiredComponents(AttributeKind kind) {
  switch (kind) {
    case AttributeKind::kVector:
    case AttributeKind::kNormal: return 3;
    case AttributeKind::kTensor: return 9;
    case AttributeKind::kRgba: return 4;
    case AttributeKind::kScalar: return 0;
  }
  return 0;
}

void checkCells(const CellArray& cells, std::size_t npoints, std::string_view name) {
  const auto invalid = [&](const std::string& what) {
    throw InvalidArgumentError("POLYDATA " + std::string(name) + ": " + what);
  };
  if (cells.offsets.empty()) {
    if (!cells.indices.empty()) invalid("indices given without offsets");
    return;
  }
  if (cells.offsets.front() != 0 || cells.offsets.back() != cells.indices.size()) {
    invalid("offsets must start at 0 and end at indices.size()");
  }
  for (std::size_t c = 1; c < cells.offsets.size(); ++c) {
    if (cells.offsets[c] < cells.offsets[c - 1]) invalid("offsets decrease at cell " + std::to_string(c - 1));
  }
  for (const auto i : cells.indices) {
    if (i >= npoints) invalid("index " + std::to_string(i) + " is beyond the " + std::to_string(npoints) + " points");
  }
  if (cells.wireBytes() > 0xFFFFFFFFULL) invalid("more than 4 GiB of cell data");
}

void writeCells(ByteWriter& w, const CellArray& cells) {
  for (std::size_t c = 0; c < cells.size(); ++c) {
    const auto cell = cells.cell(c);
    w.u32(static_cast<std::uint32_t>(cell.size()));
    w.u32Array(cell.data(), cell.size());
  }
}

CellArray readCells(ByteReader& r, std::uint32_t count, std::uint32_t size_bytes, std::uint32_t npoints,
                    std::string_view count_field, std::string_view size_field) {
  if (size_bytes % 4 != 0) r.fail(size_field, "is " + std::to_string(size_bytes) + ", not a multiple of 4");
  r.require(size_bytes, size_field);
  const std::uint32_t words = size_bytes / 4;
  // Each cell takes at least its count word, so this bounds the allocation by the data present.
  if (count > words) {
    r.fail(count_field, "is " + std::to_string(count) + " but " + std::string(size_field) + " only holds " +
                            std::to_string(words) + " words");
  }
  CellArray cells;
  if (count == 0) {
    if (words != 0) r.fail(size_field, "is non-zero for zero cells");
    return cells;
  }
  cells.offsets.reserve(std::size_t{count} + 1);
  cells.indices.resize(words - count);
  cells.offsets.push_back(0);
  std::uint32_t used = 0;
  std::uint32_t filled = 0;
  for (std::uint32_t c = 0; c < count; ++c) {
    const std::uint32_t n = r.u32(count_field);
    ++used;
    // Every later cell still needs its count word: n may use only what is left after those.
    if (n > words - used - (count - 1 - c)) {
      r.fail(size_field, "is too small: cell " + std::to_string(c) + " claims " + std::to_string(n) + " points");
    }
    r.u32Array(cells.indices.data() + filled, n, size_field);
    for (std::uint32_t k = 0; k < n; ++k) {
      if (cells.indices[filled + k] >= npoints) {
        r.fail(size_field, "cell " + std::to_string(c) + " has index " + std::to_string(cells.indices[filled + k]) +
                               " beyond the " + std::to_string(npoints) + " points");
      }
    }
    used += n;
    filled += n;
    cells.offsets.push_back(filled);
  }
  if (used != words) {
    r.fail(size_field, "is " + std::to_string(size_bytes) + " bytes but the " + std::to_string(count) + " cells use " +
                           std::to_string(std::uint64_t{used} * 4));
  }
  return cells;
}

}  // namespace

void encodePolyData(const PolyDataContent& c, std::vector<std::uint8_t>& out) {
  const std::size_t npoints = static_cast<std::size_t>(c.points.rows());
  if (npoints > 0xFFFFFFFFULL / 12) throw InvalidArgumentError("POLYDATA has too many points for one message");
  checkCells(c.vertices, npoints, "vertices");
  checkCells(c.lines, npoints, "lines");
  checkCells(c.polygons, npoints, "polygons");
  checkCells(c.triangle_strips, npoints, "triangle_strips");
  std::uint64_t total = kPolyDataHeaderSize + 12 * npoints + c.vertices.wireBytes() + c.lines.wireBytes() +
                        c.polygons.wireBytes() + c.triangle_strips.wireBytes();
  std::size_t names = 0;
  for (const auto& a : c.attributes) {
    const int required = requiredComponents(a.kind);
    if (a.data.cols() < 1 || a.data.cols() > 255 || (required != 0 && a.data.cols() != required)) {
      throw InvalidArgumentError("POLYDATA attribute '" + a.name + "' has " + std::to_string(a.data.cols()) +
                                 " components; vectors/normals need 3, tensors 9, RGBA 4, scalars 1-255");
    }
    if (a.name.size() > kMaxAttributeNameLength || a.name.find('\0') != std::string::npos) {
      throw InvalidArgumentError("POLYDATA attribute name '" + a.name + "' is longer than 255 or contains NUL");
    }
    names += a.name.size() + 1;
    total += 6 + a.name.size() + 1 + 4 * static_cast<std::uint64_t>(a.data.size());
  }
  total += names % 2;
  out.reserve(out.size() + static_cast<std::size_t>(total));
  ByteWriter w(out);
  w.u32(static_cast<std::uint32_t>(npoints));
  const CellArray* arrays[] = {&c.vertices, &c.lines, &c.polygons, &c.triangle_strips};
  for (const auto* a : arrays) {
    w.u32(static_cast<std::uint32_t>(a->size()));
    w.u32(static_cast<std::uint32_t>(a->wireBytes()));
  }
  w.u32(static_cast<std::uint32_t>(c.attributes.size()));
  w.f32Array(c.points.data(), npoints * 3);
  for (const auto* a : arrays) writeCells(w, *a);
  for (const auto& a : c.attributes) {
    w.u8(static_cast<std::uint8_t>(static_cast<std::uint8_t>(a.kind) | (a.cell_data ? kCellDataBit : 0)));
    w.u8(static_cast<std::uint8_t>(a.data.cols()));
    w.u32(static_cast<std::uint32_t>(a.data.rows()));
  }
  for (const auto& a : c.attributes) {
    w.fixedString(a.name, a.name.size());
    w.u8(0);
  }
  if (names % 2 != 0) w.u8(0);
  for (const auto& a : c.attributes) w.f32Array(a.data.data(), static_cast<std::size_t>(a.data.size()));
}

PolyDataContent decodePolyData(std::span<const std::uint8_t> content) {
  ByteReader r(content, "POLYDATA content");
  const std::uint32_t npoints = r.u32("npoints");
  std::uint32_t counts[4];
  std::uint32_t sizes[4];
  for (int i = 0; i < 4; ++i) {
    counts[i] = r.u32("ncells");
    sizes[i] = r.u32("size_cells");
  }
  const std::uint32_t nattributes = r.u32("nattributes");
  PolyDataContent c;
  r.require(std::uint64_t{npoints} * 12, "points");
  c.points.resize(npoints, 3);
  r.f32Array(c.points.data(), std::size_t{npoints} * 3, "points");
  CellArray* arrays[] = {&c.vertices, &c.lines, &c.polygons, &c.triangle_strips};
  static constexpr std::string_view kCountFields[] = {"nvertices", "nlines", "npolygons", "ntriangle_strips"};
  static constexpr std::string_view kSizeFields[] = {"size_vertices", "size_lines", "size_polygons",
                                                     "size_triangle_strips"};
  for (int i = 0; i < 4; ++i) *arrays[i] = readCells(r, counts[i], sizes[i], npoints, kCountFields[i], kSizeFields[i]);

  // Each attribute needs at least a 6-byte header, a NUL and no data: bound before reserving.
  if (std::uint64_t{nattributes} * 7 > r.remaining()) {
    r.fail("nattributes", "is " + std::to_string(nattributes) + ", more than the remaining bytes can hold");
  }
  struct Pending {
    std::uint8_t type;
    std::uint8_t components;
    std::uint32_t n;
  };
  std::vector<Pending> pending(nattributes);
  for (auto& p : pending) {
    p.type = r.u8("attribute type");
    p.components = r.u8("attribute ncomponents");
    p.n = r.u32("attribute n");
    const std::uint8_t kind = p.type & 0x0F;
    if (kind > 4 || (p.type & 0xE0) != 0) {
      r.fail("attribute type", "is " + std::to_string(p.type) + "; expected 0-4 (point data) or 16-20 (cell data)");
    }
    const int required = requiredComponents(static_cast<AttributeKind>(kind));
    if (p.components == 0 || (required != 0 && p.components != required)) {
      r.fail("attribute ncomponents",
             "is " + std::to_string(p.components) + " for attribute type " + std::to_string(p.type));
    }
  }
  c.attributes.resize(nattributes);
  std::size_t names = 0;
  for (auto& a : c.attributes) {
    a.name = r.cString(kMaxAttributeNameLength, "attribute name");
    names += a.name.size() + 1;
  }
  if (names % 2 != 0) r.u8("attribute name padding");
  for (std::uint32_t i = 0; i < nattributes; ++i) {
    const auto& p = pending[i];
    auto& a = c.attributes[i];
    a.kind = static_cast<AttributeKind>(p.type & 0x0F);
    a.cell_data = (p.type & kCellDataBit) != 0;
    const std::uint64_t values = std::uint64_t{p.n} * p.components;
    r.require(values * 4, "attribute data");
    a.data.resize(p.n, p.components);
    r.f32Array(a.data.data(), static_cast<std::size_t>(values), "attribute data");
  }
  r.expectEnd("the last attribute");
  return c;
}

}  // namespace mrsns::igtlink
