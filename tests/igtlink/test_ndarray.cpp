// NDARRAY (float32) bodies: the layout byte for byte, a round trip, and every malformed body refused with
// the field it stopped at.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/ndarray.h"

namespace mrsns::igtlink {
namespace {

TEST(NdArray, LayoutIsTypeDimensionSizesThenBigEndianValues) {
  NdArrayFloat32 a;
  a.size = {2, 3};
  a.values = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, -1.5f};
  const auto bytes = encodeNdArray(a);
  ASSERT_EQ(bytes.size(), 2u + 2u * 2u + 4u * 6u);
  EXPECT_EQ(bytes[0], 10);  // float32
  EXPECT_EQ(bytes[1], 2);   // dimensions
  EXPECT_EQ(bytes[2], 0);
  EXPECT_EQ(bytes[3], 2);
  EXPECT_EQ(bytes[4], 0);
  EXPECT_EQ(bytes[5], 3);
  // 1.0f = 0x3F800000, big-endian first.
  EXPECT_EQ(bytes[6], 0x3F);
  EXPECT_EQ(bytes[7], 0x80);
  EXPECT_EQ(bytes[8], 0x00);
  EXPECT_EQ(bytes[9], 0x00);
  const NdArrayFloat32 back = decodeNdArray(bytes);
  EXPECT_EQ(back.size, a.size);
  EXPECT_EQ(back.values, a.values);
}

TEST(NdArray, MalformedBodiesAreRefusedNamingTheField) {
  NdArrayFloat32 a;
  a.size = {2, 3};
  a.values.assign(6, 0.5f);
  const auto good = encodeNdArray(a);
  auto refused = [](std::vector<std::uint8_t> body, const std::string& field) {
    try {
      (void)decodeNdArray(body);
      ADD_FAILURE() << "accepted a body that should name " << field;
    } catch (const FormatError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  refused({}, "scalar type");
  refused(std::vector<std::uint8_t>(good.begin(), good.end() - 1), "value");  // truncated
  auto extra = good;
  extra.push_back(0);
  refused(extra, "NDARRAY content");  // trailing byte
  auto int8 = good;
  int8[0] = 2;
  refused(int8, "scalar type");
  auto no_dim = good;
  no_dim[1] = 0;
  refused(no_dim, "dimension");
  auto zero = good;
  zero[3] = 0;
  refused(zero, "size");
  // A size table claiming more values than the body holds (a hostile 65535 x 65535) is refused, not allocated.
  std::vector<std::uint8_t> huge = {10, 2, 0xFF, 0xFF, 0xFF, 0xFF, 0, 0, 0, 0};
  refused(huge, "values");
}

TEST(NdArray, BadArraysAreNotEncoded) {
  NdArrayFloat32 a;
  EXPECT_THROW((void)encodeNdArray(a), InvalidArgumentError);  // no dimension
  a.size = {2, 0};
  EXPECT_THROW((void)encodeNdArray(a), InvalidArgumentError);
  a.size = {2, 3};
  a.values.assign(5, 0.0f);
  EXPECT_THROW((void)encodeNdArray(a), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::igtlink
