#pragma once
// Shared helpers of the igtlink tests: reference files and random contents.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "mrsns/igtlink/message.h"

namespace mrsns::igtlink::test {

inline std::vector<std::uint8_t> readBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Every complete reference message (file name -> bytes), or the header+body
/// pairs concatenated under their common stem.
struct ReferenceMessage {
  std::string name;
  std::vector<std::uint8_t> bytes;
};

/// The float32 nearest to `v` (what survives a trip through the wire).
inline double f32(double v) {
  // volatile: GCC 12's SLP vectoriser (-O2) drops a double->float->double round trip when two of
  // them feed Eigen::Vector3d(x, y, z) (reproduced in 10 lines; clang and -fno-tree-slp-vectorize are fine).
  volatile float narrowed = static_cast<float>(v);
  return narrowed;
}

class RandomContents {
 public:
  explicit RandomContents(std::uint32_t seed) : rng_(seed) {}

  double uniform(double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng_); }
  int integer(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  std::string text(std::size_t max_length) {
    std::string s(static_cast<std::size_t>(integer(0, static_cast<int>(max_length))), ' ');
    for (auto& c : s) c = static_cast<char>(integer(33, 126));
    return s;
  }
  /// A float32-representable value (so decode(encode(x)) == x exactly).
  double value(double scale = 100.0) { return f32(uniform(-scale, scale)); }
  Eigen::Matrix4d matrix() {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) m(r, c) = value(c == 3 ? 500.0 : 1.0);
    return m;
  }

  TransformContent transform() { return {matrix()}; }
  PositionContent position() {
    PositionContent p;
    p.position = Eigen::Vector3d(value(), value(), value());
    p.quaternion_components = 4;
    p.orientation = Eigen::Quaterniond(value(1), value(1), value(1), value(1));
    return p;
  }
  TrackingDataContent tdata() {
    TrackingDataContent t;
    const int n = integer(0, 5);
    for (int i = 0; i < n; ++i) t.elements.push_back({text(20), static_cast<std::uint8_t>(integer(1, 4)), matrix()});
    return t;
  }
  ImageContent image() {
    ImageContent im;
    const std::uint8_t types[] = {2, 3, 4, 5, 6, 7, 10, 11};
    im.scalar_type = static_cast<ScalarType>(types[integer(0, 7)]);
    im.components = static_cast<std::uint8_t>(integer(1, 3));
    im.endian = integer(0, 1) ? PixelEndian::kBig : PixelEndian::kLittle;
    im.coordinate = integer(0, 1) ? ImageCoordinate::kRas : ImageCoordinate::kLps;
    im.size = {static_cast<std::uint16_t>(integer(1, 9)), static_cast<std::uint16_t>(integer(1, 9)),
               static_cast<std::uint16_t>(integer(1, 4))};
    im.subvolume_offset = {static_cast<std::uint16_t>(integer(0, im.size[0] - 1)), 0, 0};
    im.subvolume_size = {static_cast<std::uint16_t>(im.size[0] - im.subvolume_offset[0]), im.size[1], im.size[2]};
    im.ijk_to_xyz = matrix();
    im.pixels.resize(static_cast<std::size_t>(im.expectedPixelBytes()));
    for (auto& b : im.pixels) b = static_cast<std::uint8_t>(integer(0, 255));
    return im;
  }
  CellArray cells(std::uint32_t npoints, int max_cells, int max_corners) {
    CellArray c;
    if (npoints == 0) return c;
    const int n = integer(0, max_cells);
    for (int i = 0; i < n; ++i) {
      std::vector<std::uint32_t> cell(static_cast<std::size_t>(integer(1, max_corners)));
      for (auto& v : cell) v = static_cast<std::uint32_t>(integer(0, static_cast<int>(npoints) - 1));
      c.add(cell);
    }
    return c;
  }
  PolyDataContent polydata() {
    PolyDataContent p;
    const int np = integer(0, 30);
    p.points.resize(np, 3);
    for (int i = 0; i < np * 3; ++i) p.points.data()[i] = value();
    const auto n = static_cast<std::uint32_t>(np);
    p.vertices = cells(n, 3, 1);
    p.lines = cells(n, 4, 4);
    p.polygons = cells(n, 10, 5);
    p.triangle_strips = cells(n, 3, 6);
    const int na = integer(0, 4);
    for (int i = 0; i < na; ++i) {
      PolyDataAttribute a;
      a.kind = static_cast<AttributeKind>(integer(0, 4));
      a.cell_data = integer(0, 1) == 1;
      a.name = text(12);
      const int comps[] = {integer(1, 4), 3, 3, 9, 4};
      a.data.resize(np, comps[static_cast<int>(a.kind)]);
      for (Eigen::Index k = 0; k < a.data.size(); ++k) a.data.data()[k] = value(1.0);
      p.attributes.push_back(std::move(a));
    }
    return p;
  }
  StringContent string() { return {integer(0, 1) ? kEncodingUsAscii : kEncodingUtf8, text(200)}; }
  StatusContent status() {
    return {static_cast<std::uint16_t>(integer(0, 19)), static_cast<std::int64_t>(integer(-100000, 100000)), text(20),
            text(100)};
  }
  PointContent point() {
    PointContent pc;
    const int n = integer(0, 4);
    for (int i = 0; i < n; ++i) {
      PointElement e;
      e.name = text(64);
      e.group = text(32);
      for (auto& c : e.rgba) c = static_cast<std::uint8_t>(integer(0, 255));
      e.position = Eigen::Vector3d(value(), value(), value());
      e.radius = f32(uniform(0, 10));
      e.owner = text(20);
      pc.points.push_back(std::move(e));
    }
    return pc;
  }
  CapabilityContent capability() {
    CapabilityContent c;
    const int n = integer(0, 6);
    for (int i = 0; i < n; ++i) c.types.push_back(text(12));
    return c;
  }

 private:
  std::mt19937 rng_;
};

}  // namespace mrsns::igtlink::test
