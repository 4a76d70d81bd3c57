// OpenIGTLink codec (mrsns::igtlink) against Debian's libopenigtlink 1.11 on
// the same messages: TRANSFORM, IMAGE (820x616 uint8, an ultrasound frame)
// and POLYDATA (100k triangles). Both sides compute/check the CRC-64.
// Run: build/tests/benchmarks/mrsns_bench_igtlink_codec
#include <benchmark/benchmark.h>
#include <igtlImageMessage.h>
#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlTransformMessage.h>
#include <igtl_header.h>

#include <cstring>
#include <vector>

#include "mrsns/igtlink/codec.h"

namespace {

using namespace mrsns::igtlink;

constexpr int kWidth = 820;
constexpr int kHeight = 616;
constexpr int kGrid = 224;  // (224-1)^2 * 2 = 99,458 triangles on 50,176 points

std::vector<std::uint8_t> packed(igtl::MessageBase* m) {
  m->Pack();
  const auto* p = static_cast<const std::uint8_t*>(m->GetPackPointer());
  return {p, p + m->GetPackSize()};
}

template <typename T>
void peerUnpack(const std::vector<std::uint8_t>& bytes, T* message) {
  // A fresh header and message per receive, as the library's examples do (reused ones refuse the second Unpack).
  auto header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), IGTL_HEADER_SIZE);
  header->Unpack();
  message->SetMessageHeader(header);
  message->AllocatePack();
  std::memcpy(message->GetPackBodyPointer(), bytes.data() + IGTL_HEADER_SIZE,
              static_cast<std::size_t>(message->GetPackBodySize()));
  if (!(message->Unpack(1) & igtl::MessageHeader::UNPACK_BODY)) throw std::runtime_error("peer refused the message");
}

Message transformMessage() {
  Eigen::Isometry3d t = Eigen::Translation3d(10, 20, 30) * Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitY());
  return makeMessage("ProbeToTracker", TransformContent::fromIsometry(t));
}

igtl::TransformMessage::Pointer peerTransform() {
  auto m = igtl::TransformMessage::New();
  m->SetDeviceName("ProbeToTracker");
  igtl::Matrix4x4 mat;
  const Message source = transformMessage();
  const Eigen::Matrix4d src = source.as<TransformContent>()->matrix;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) mat[r][c] = static_cast<float>(src(r, c));
  m->SetMatrix(mat);
  return m;
}

Message imageMessage() {
  ImageContent im;
  im.setGeometry({0.2, 0.2, 1.0}, Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  im.resizeWhole({kWidth, kHeight, 1});
  for (std::size_t i = 0; i < im.pixels.size(); ++i) im.pixels[i] = static_cast<std::uint8_t>(i * 31);
  return makeMessage("Image_Probe", im);
}

igtl::ImageMessage::Pointer peerImage() {
  auto m = igtl::ImageMessage::New();
  m->SetDeviceName("Image_Probe");
  m->SetDimensions(kWidth, kHeight, 1);
  m->SetSpacing(0.2f, 0.2f, 1.0f);
  m->SetScalarTypeToUint8();
  m->AllocateScalars();
  const Message source = imageMessage();
  const auto& pixels = source.as<ImageContent>()->pixels;
  std::memcpy(m->GetScalarPointer(), pixels.data(), pixels.size());
  return m;
}

Message polyDataMessage() {
  PolyDataContent p;
  p.points.resize(kGrid * kGrid, 3);
  for (int y = 0; y < kGrid; ++y)
    for (int x = 0; x < kGrid; ++x) p.points.row(y * kGrid + x) = Eigen::RowVector3d(x, y, 0.01 * x * y);
  for (std::uint32_t y = 0; y + 1 < kGrid; ++y) {
    for (std::uint32_t x = 0; x + 1 < kGrid; ++x) {
      const std::uint32_t i = y * kGrid + x;
      p.polygons.add({i, i + 1, i + kGrid});
      p.polygons.add({i + 1, i + kGrid + 1, i + kGrid});
    }
  }
  return makeMessage("Vertebra_C5", p);
}

igtl::PolyDataMessage::Pointer peerPolyData() {
  const Message source = polyDataMessage();
  const auto& p = *source.as<PolyDataContent>();
  auto m = igtl::PolyDataMessage::New();
  m->SetDeviceName("Vertebra_C5");
  auto points = igtl::PolyDataPointArray::New();
  for (Eigen::Index i = 0; i < p.points.rows(); ++i) {
    points->AddPoint(static_cast<float>(p.points(i, 0)), static_cast<float>(p.points(i, 1)),
                     static_cast<float>(p.points(i, 2)));
  }
  auto polygons = igtl::PolyDataCellArray::New();
  for (std::size_t c = 0; c < p.polygons.size(); ++c) {
    std::vector<igtlUint32> cell(p.polygons.cell(c).begin(), p.polygons.cell(c).end());
    polygons->AddCell(3, cell.data());
  }
  m->SetPoints(points);
  m->SetPolygons(polygons);
  return m;
}

void setBytes(benchmark::State& state, std::size_t bytes) {
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(bytes));
}

// ---- TRANSFORM
void BM_Transform_Encode_Mrsns(benchmark::State& state) {
  const Message m = transformMessage();
  for (auto _ : state) benchmark::DoNotOptimize(encodeMessage(m));
}
void BM_Transform_Encode_LibOpenIGTLink(benchmark::State& state) {
  auto m = peerTransform();
  for (auto _ : state) {
    m->Pack();
    benchmark::DoNotOptimize(m->GetPackPointer());
  }
}
void BM_Transform_Decode_Mrsns(benchmark::State& state) {
  const auto bytes = encodeMessage(transformMessage());
  for (auto _ : state) benchmark::DoNotOptimize(decodeMessage(bytes));
}
void BM_Transform_Decode_LibOpenIGTLink(benchmark::State& state) {
  const auto bytes = packed(peerTransform());
  for (auto _ : state) {
    auto m = igtl::TransformMessage::New();
    peerUnpack(bytes, m.GetPointer());
  }
}

// ---- IMAGE
void BM_Image_Encode_Mrsns(benchmark::State& state) {
  const Message m = imageMessage();
  std::size_t size = 0;
  for (auto _ : state) {
    auto b = encodeMessage(m);
    size = b.size();
    benchmark::DoNotOptimize(b);
  }
  setBytes(state, size);
}
void BM_Image_Encode_LibOpenIGTLink(benchmark::State& state) {
  auto m = peerImage();
  for (auto _ : state) {
    m->Pack();
    benchmark::DoNotOptimize(m->GetPackPointer());
  }
  setBytes(state, static_cast<std::size_t>(m->GetPackSize()));
}
void BM_Image_Decode_Mrsns(benchmark::State& state) {
  const auto bytes = encodeMessage(imageMessage());
  for (auto _ : state) benchmark::DoNotOptimize(decodeMessage(bytes));
  setBytes(state, bytes.size());
}
void BM_Image_Decode_LibOpenIGTLink(benchmark::State& state) {
  const auto bytes = packed(peerImage());
  for (auto _ : state) {
    auto m = igtl::ImageMessage::New();
    peerUnpack(bytes, m.GetPointer());
  }
  setBytes(state, bytes.size());
}

// ---- POLYDATA
void BM_PolyData_Encode_Mrsns(benchmark::State& state) {
  const Message m = polyDataMessage();
  std::size_t size = 0;
  for (auto _ : state) {
    auto b = encodeMessage(m);
    size = b.size();
    benchmark::DoNotOptimize(b);
  }
  setBytes(state, size);
}
void BM_PolyData_Encode_LibOpenIGTLink(benchmark::State& state) {
  auto m = peerPolyData();
  for (auto _ : state) {
    m->Pack();
    benchmark::DoNotOptimize(m->GetPackPointer());
  }
  setBytes(state, static_cast<std::size_t>(m->GetPackSize()));
}
void BM_PolyData_Decode_Mrsns(benchmark::State& state) {
  const auto bytes = encodeMessage(polyDataMessage());
  for (auto _ : state) benchmark::DoNotOptimize(decodeMessage(bytes));
  setBytes(state, bytes.size());
}
void BM_PolyData_Decode_LibOpenIGTLink(benchmark::State& state) {
  const auto bytes = packed(peerPolyData());
  for (auto _ : state) {
    auto m = igtl::PolyDataMessage::New();
    peerUnpack(bytes, m.GetPointer());
  }
  setBytes(state, bytes.size());
}

BENCHMARK(BM_Transform_Encode_Mrsns);
BENCHMARK(BM_Transform_Encode_LibOpenIGTLink);
BENCHMARK(BM_Transform_Decode_Mrsns);
BENCHMARK(BM_Transform_Decode_LibOpenIGTLink);
BENCHMARK(BM_Image_Encode_Mrsns)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Image_Encode_LibOpenIGTLink)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Image_Decode_Mrsns)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Image_Decode_LibOpenIGTLink)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_PolyData_Encode_Mrsns)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PolyData_Encode_LibOpenIGTLink)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PolyData_Decode_Mrsns)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PolyData_Decode_LibOpenIGTLink)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
