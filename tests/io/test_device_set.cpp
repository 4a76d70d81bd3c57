// PLUS device-set configuration: the real fCal 1.2 file and malformed XML.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/io/device_set.h"
#include "test_data.h"

namespace mrsns {
namespace {

using ::testing::HasSubstr;

TEST(DeviceSet, RealFcalConfiguration) {
  MRSNS_REQUIRE_DATA(path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const io::DeviceSetConfiguration config = io::readDeviceSet(path);
  EXPECT_THAT(config.name, HasSubstr("fCal Phantom 1.2 - 3Nwires"));

  const io::PhantomDefinition& phantom = config.requirePhantom();
  EXPECT_EQ(phantom.name, "fCAL");
  EXPECT_EQ(phantom.type, "Multi-N");
  EXPECT_EQ(phantom.version, "1.2");
  ASSERT_EQ(phantom.patterns.size(), 3u);
  EXPECT_EQ(phantom.wireCount(), 9u);
  for (const auto& pattern : phantom.patterns) {
    EXPECT_EQ(pattern.type, "NWire");
    EXPECT_EQ(pattern.wires.size(), 3u);
  }
  const io::PhantomWire& diagonal = phantom.patterns[0].wires[1];
  EXPECT_EQ(diagonal.name, "2:I2_f2");
  EXPECT_EQ(diagonal.end_point_front, Eigen::Vector3d(40.0, 0.0, 10.0));
  EXPECT_EQ(diagonal.end_point_back, Eigen::Vector3d(25.0, 40.0, 10.0));
  EXPECT_EQ(phantom.patterns[2].wires[2].name, "9:K4_k4");
  // Every N lies in one plane (constant z): the phantom's geometry, not a parse artefact.
  for (const auto& pattern : phantom.patterns) {
    for (const auto& wire : pattern.wires) {
      EXPECT_EQ(wire.end_point_front.z(), pattern.wires[0].end_point_front.z());
      EXPECT_EQ(wire.end_point_back.z(), wire.end_point_front.z());
    }
  }
  ASSERT_EQ(phantom.landmarks.size(), 8u);
  EXPECT_EQ(phantom.landmarks[0].name, "#1");
  EXPECT_EQ(phantom.landmarks[5].position_phantom, Eigen::Vector3d(-25.0, 0.0, 10.0));

  ASSERT_EQ(config.coordinate_definitions.size(), 3u);
  const auto phantom_to_reference = config.findTransform("Phantom", "Reference");
  ASSERT_TRUE(phantom_to_reference.has_value());
  EXPECT_EQ(phantom_to_reference->name(), "PhantomToReference");
  EXPECT_EQ(phantom_to_reference->to_T_from(0, 3), 9.59137);
  EXPECT_EQ(phantom_to_reference->to_T_from(2, 0), -0.999657);
  EXPECT_EQ(phantom_to_reference->to_T_from.row(3), Eigen::RowVector4d(0, 0, 0, 1));
  EXPECT_EQ(phantom_to_reference->error, 0.404711);
  EXPECT_EQ(phantom_to_reference->date, "012712_152104");
  const auto image_to_origin = config.findTransform("Image", "TransducerOriginPixel");
  ASSERT_TRUE(image_to_origin.has_value());
  EXPECT_EQ(image_to_origin->to_T_from(0, 3), -410.0);
  EXPECT_FALSE(image_to_origin->error.has_value());
  EXPECT_FALSE(config.findTransform("Reference", "Phantom").has_value());

  ASSERT_TRUE(config.segmentation.has_value());
  const io::SegmentationParameters& s = *config.segmentation;
  EXPECT_EQ(s.approximate_spacing_mm_per_pixel, 0.078);
  EXPECT_EQ(s.morphological_opening_circle_radius_mm, 0.27);
  EXPECT_EQ(s.max_line_pair_distance_error_percent, 10.0);
  EXPECT_DOUBLE_EQ(*s.angle_tolerance, 10.0 * std::numbers::pi / 180.0);
  EXPECT_DOUBLE_EQ(*s.min_theta, -70.0 * std::numbers::pi / 180.0);
  EXPECT_EQ(s.clip_rectangle_origin_px, (std::array<int, 2>{27, 27}));
  EXPECT_EQ(s.clip_rectangle_size_px, (std::array<int, 2>{766, 562}));
  EXPECT_EQ(s.use_original_image_intensity_for_dot_intensity_score, false);
  EXPECT_EQ(s.number_of_maximum_fiducial_point_candidates, 20);
  EXPECT_EQ(s.attributes.size(), 15u);
  EXPECT_EQ(s.attribute("MaxThetaDegrees"), "70");
  EXPECT_EQ(s.attributes.front().first, "ApproximateSpacingMmPerPixel");
}

std::string wrap(const std::string& body) {
  return "<PlusConfiguration version=\"2.1\">" + body + "</PlusConfiguration>";
}

std::string formatErrorOf(const std::string& xml) {
  try {
    (void)io::parseDeviceSet(xml, "test.xml");
  } catch (const FormatError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected FormatError for " << xml;
  return {};
}

TEST(DeviceSet, MalformedInputIsReportedWithItsPlace) {
  EXPECT_THAT(formatErrorOf("<PlusConfiguration><Device></PlusConfiguration>"), HasSubstr("not well-formed XML"));
  EXPECT_THAT(formatErrorOf("<Other/>"), HasSubstr("<Other>"));
  EXPECT_THAT(formatErrorOf(wrap("<CoordinateDefinitions><Transform From=\"A\" To=\"B\" Matrix=\"1 0 0\"/>"
                                 "</CoordinateDefinitions>")),
              HasSubstr("Matrix: expected 16 numbers"));
  EXPECT_THAT(formatErrorOf(wrap("<CoordinateDefinitions><Transform To=\"B\" Matrix=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 "
                                 "1\"/></CoordinateDefinitions>")),
              HasSubstr("From: is missing"));
  EXPECT_THAT(formatErrorOf(wrap("<PhantomDefinition><Geometry><Pattern Type=\"NWire\">"
                                 "<Wire Name=\"1\" EndPointFront=\"0 0 a\" EndPointBack=\"0 0 0\"/>"
                                 "</Pattern></Geometry></PhantomDefinition>")),
              HasSubstr("'a' is not a number"));
  EXPECT_THAT(formatErrorOf(wrap("<PhantomDefinition><Geometry><Pattern Type=\"NWire\">"
                                 "<Wire Name=\"1\" EndPointFront=\"0 0 0\" EndPointBack=\"0 0 1\"/>"
                                 "</Pattern></Geometry></PhantomDefinition>")),
              HasSubstr("needs 3 wires"));
  EXPECT_THAT(formatErrorOf(wrap("<Segmentation ClipRectangleOrigin=\"1.5 2\"/>")), HasSubstr("ClipRectangleOrigin"));
  EXPECT_THAT(formatErrorOf(wrap("<Segmentation UseOriginalImageIntensityForDotIntensityScore=\"maybe\"/>")),
              HasSubstr("TRUE or FALSE"));
}

TEST(DeviceSet, MissingPhantomIsAClearErrorOnlyWhenAskedFor) {
  const io::DeviceSetConfiguration config = io::parseDeviceSet(wrap(""), "empty.xml");
  EXPECT_FALSE(config.phantom.has_value());
  EXPECT_FALSE(config.segmentation.has_value());
  try {
    (void)config.requirePhantom();
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    EXPECT_THAT(e.what(), HasSubstr("empty.xml"));
    EXPECT_THAT(e.what(), HasSubstr("PhantomDefinition"));
  }
  EXPECT_THROW((void)io::readDeviceSet("/nonexistent/device.xml"), FileError);
}

}  // namespace
}  // namespace mrsns
