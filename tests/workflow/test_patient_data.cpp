// Preparation on the user's own data: the real TotalSegmentator CT of the
// shared data made into a session from scratch (CT, vertebra and organ label
// maps, models, bilateral pedicle screws at two levels with their figures),
// saved and reopened; and the bad input a user brings, refused with a message
// that says what to do and nothing lost.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/screw_path_io.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/workflow/steps.h"
#include "cli_runner.h"
#include "required_tool.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr const char* kCt = "ct/totalsegmentator/example_ct.nii.gz";
constexpr const char* kVertebrae = "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz";
constexpr const char* kOrgans = "ct/totalsegmentator/example_seg.nii.gz";

/// Bilateral pedicle screws at L1 and L2, planned by reading the figures on this 3 mm CT (6 mm x 45 mm).
struct Plan {
  const char* name;
  Eigen::Vector3d entry, target;
};
const Plan kPlans[] = {{"L1 left", {25.5, -84.0, 382.0}, {5.5, -134.0, 382.0}},
                       {"L1 right", {-18.5, -84.0, 382.0}, {1.5, -134.0, 382.0}},
                       {"L2 left", {24.0, -92.0, 350.0}, {10.0, -142.0, 356.0}},
                       {"L2 right", {-17.0, -93.0, 355.0}, {-5.0, -143.0, 358.0}}};

Json point(const Eigen::Vector3d& p) {
  return Json::array({p.x(), p.y(), p.z()});
}

StepResult run(Session& s, const std::string& step, const Json& params) {
  return runStep(s, step, params, {});
}

/// The CT and both label maps in a new session (the organs' crop aligned onto the vertebrae: its header keeps
/// the whole image's origin, see RealCropWithAStaleHeaderIsRefusedThenAlignedByItsVertebrae).
Session realSession(const fs::path& dir, const fs::path& ct, const fs::path& vertebrae, const fs::path& organs) {
  auto s = Session::create(dir);
  EXPECT_TRUE(run(s, "import-ct", {{"path", ct.string()}}).ok);
  EXPECT_TRUE(run(s, "import-label-map", {{"path", vertebrae.string()}}).ok);
  EXPECT_TRUE(run(s, "import-label-map", {{"path", organs.string()}, {"align_to", "labels"}}).ok);
  return s;
}

TEST(PatientData, RealCtToModelsAndBilateralScrewsAtTwoLevelsSavedAndReopened) {
  MRSNS_REQUIRE_DATA(ct, kCt);
  MRSNS_REQUIRE_DATA(vertebrae, kVertebrae);
  MRSNS_REQUIRE_DATA(organs, kOrgans);
  const auto dir = test::scratchDirectory("s") / "session";
  auto s = realSession(dir, ct, vertebrae, organs);
  ASSERT_TRUE(s.ct().has_value());
  EXPECT_EQ(s.ct()->size_px, (std::array<int, 3>{122, 101, 112}));
  EXPECT_EQ(s.ct()->format, "nifti");
  ASSERT_EQ(s.labelMaps().size(), 2u);
  EXPECT_EQ(s.labelMaps()[0].scheme, "totalsegmentator");
  EXPECT_EQ(s.labelMaps()[1].placement, "aligned");

  // L1-L4 from the vertebra labels: closed surfaces whose enclosed volume matches their voxels within what
  // 3 mm voxels allow (surface area x half a voxel edge).
  const auto models = run(s, "make-models", {{"label_map", "labels"}, {"labels", "L1,L2,L3,L4"}});
  ASSERT_TRUE(models.ok) << models.summary;
  for (const char* level : {"L1", "L2", "L3", "L4"}) {
    SCOPED_TRACE(level);
    const auto m = s.model(level);
    ASSERT_TRUE(m.has_value());
    EXPECT_EQ(m->role, ModelRole::Bone);
    EXPECT_EQ(m->vertebra, level);
    const auto mesh = io::readMesh(s.resolve(m->file));
    EXPECT_TRUE(isClosed(mesh));
    EXPECT_NEAR(signedVolume(mesh) / 1000.0, m->voxel_volume_ml, m->volume_tolerance_ml);
    EXPECT_GT(m->voxel_volume_ml, 40.0) << "a whole lumbar vertebra is 50-70 ml";
    EXPECT_LT(m->voxel_volume_ml, 80.0);
    ASSERT_FALSE(m->hmd_file.empty());
    EXPECT_LE(m->hmd_triangles, 20000u);
  }
  // The vessels, the spinal cord and the muscles beside the spine, from the organs' label map.
  ASSERT_TRUE(run(s, "make-models",
                  {{"label_map", "labels-2"},
                   {"labels", "aorta,inferior_vena_cava,spinal_cord,autochthon_left,autochthon_right"}})
                  .ok);
  EXPECT_EQ(s.models(ModelRole::Vessel).size(), 2u);
  EXPECT_EQ(s.models(ModelRole::Neural).size(), 1u);
  EXPECT_EQ(s.models(ModelRole::SoftTissue).size(), 2u);

  for (const auto& p : kPlans) {
    const auto r = run(s, "plan-screw",
                       {{"name", p.name}, {"entry", point(p.entry)}, {"target", point(p.target)}, {"diameter_mm", 6.0},
                        {"length_mm", 45.0}});
    ASSERT_TRUE(r.ok) << p.name << ": " << r.summary;
  }
  const auto plans = s.plans();
  ASSERT_EQ(plans.size(), 4u);
  const MeshLocator aorta(io::readMesh(s.resolve(s.model("aorta")->file)));
  for (const auto& screw : plans) {
    SCOPED_TRACE(screw.name);
    EXPECT_EQ(screw.vertebra, screw.name.substr(0, 2)) << "the vertebra named from the anatomy";
    EXPECT_EQ(screw.side, screw.name.substr(3));
    const auto& f = screw.figures;
    ASSERT_TRUE(f["breach"].is_object()) << f.dump();
    // Planned inside the pedicles: at most a Gertzbein-Robbins B (< 2 mm) on a 3 mm CT, the whole screw in bone.
    EXPECT_LT(f["breach"]["max_breach_mm"].get<double>(), 2.0);
    EXPECT_GT(f["breach"]["length_in_bone_mm"].get<double>(), 40.0);
    ASSERT_TRUE(f["angles"].is_object());
    EXPECT_EQ(f["angles"]["side"], screw.side);
    EXPECT_GT(f["angles"]["medial_deg"].get<double>(), 0.0) << "pedicle screws converge";
    EXPECT_LT(f["angles"]["medial_deg"].get<double>(), 35.0);
    ASSERT_TRUE(f["clearance"]["vessel"].is_object());
    ASSERT_TRUE(f["clearance"]["neural"].is_object());
    EXPECT_EQ(f["clearance"]["neural"]["name"], "spinal_cord");
    EXPECT_GT(f["clearance"]["neural"]["min_clearance_mm"].get<double>(), 0.0) << "no screw enters the canal";
    // The clearance to the aorta against a brute-force search over every triangle, every 0.05 mm of the axis.
    double aorta_clearance = 1e9;
    for (const auto& structure : f["structures"]) {
      if (structure["name"] == "aorta") aorta_clearance = structure["min_clearance_mm"].get<double>();
    }
    const Eigen::Vector3d d = (screw.target - screw.entry).normalized();
    double brute = 1e9;
    for (double t = 0.0; t <= 45.0 + 1e-9; t += 0.05) {
      brute = std::min(brute, aorta.closestPointBruteForce(screw.entry + t * d).distance - 3.0);
    }
    EXPECT_NEAR(aorta_clearance, brute, 0.02);
    EXPECT_GT(aorta_clearance, 5.0) << "a pedicle screw stays in the vertebra, well behind the aorta";
  }
  // The plan as Slicer markups beside session.json.
  const auto lines = io::readMarkupsLines(s.resolve("plans/Plan.mrk.json"));
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_NE(lines[0].description.find("side=left"), std::string::npos);

  // Saved and reopened: nothing lost.
  const Json before = s.state();
  const auto reopened = Session::open(dir);
  EXPECT_EQ(reopened.state(), before);
  ASSERT_EQ(reopened.plans().size(), 4u);
  for (std::size_t i = 0; i < plans.size(); ++i) {
    EXPECT_EQ(Json(reopened.plans()[i]), Json(plans[i]));
  }
  EXPECT_EQ(reopened.models().size(), 9u);
}

TEST(PatientData, RealCropWithAStaleHeaderIsRefusedThenAlignedByItsVertebrae) {
  MRSNS_REQUIRE_DATA(ct, kCt);
  MRSNS_REQUIRE_DATA(vertebrae, kVertebrae);
  MRSNS_REQUIRE_DATA(organs, kOrgans);
  auto s = Session::create(test::scratchDirectory("s") / "session");
  ASSERT_TRUE(run(s, "import-ct", {{"path", ct.string()}}).ok);
  ASSERT_TRUE(run(s, "import-label-map", {{"path", vertebrae.string()}}).ok);
  // The organs' map is a crop of 30 of the CT's 112 slices saved with the whole image's origin: on the grid as
  // its header says, its L1 lies 246 mm (82 slices) below the vertebra map's L1.
  try {
    (void)run(s, "import-label-map", {{"path", organs.string()}});
    FAIL() << "a label map placed 246 mm off was taken";
  } catch (const FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("246.0 mm"), std::string::npos) << what;
    EXPECT_NE(what.find("align_to=labels"), std::string::npos) << what;
  }
  EXPECT_EQ(s.labelMaps().size(), 1u) << "nothing stored";
  const auto aligned = run(s, "import-label-map", {{"path", organs.string()}, {"align_to", "labels"}});
  ASSERT_TRUE(aligned.ok);
  EXPECT_EQ(aligned.figures["checks"]["shift_voxels"], Json::array({0.0, 0.0, 82.0}));
  EXPECT_GT(aligned.figures["checks"]["shared_label_dice"].get<double>(), 0.9);
  // Bone labels on bone: the mean HU under each vertebra is that of bone (TotalSegmentator's own report gives
  // 110-140 HU for the bodies alone).
  for (const auto& [name, hu] : aligned.figures["checks"]["bone_mean_hu"].items()) {
    EXPECT_GT(hu.get<double>(), 100.0) << name;
  }
}

TEST(PatientData, TheDicomSeriesImportsWithItsGeometry) {
  MRSNS_REQUIRE_DATA(dicom, "ct/totalsegmentator/example_ct_dicom");
  auto s = Session::create(test::scratchDirectory("s") / "session");
  const auto r = run(s, "import-ct", {{"path", dicom.string()}});
  ASSERT_TRUE(r.ok) << r.summary;
  const auto ct = s.ct();
  ASSERT_TRUE(ct.has_value());
  EXPECT_EQ(ct->format, "dicom");
  EXPECT_EQ(ct->modality, "CT");
  EXPECT_FALSE(ct->series_uid.empty());
  EXPECT_EQ(r.figures["dicom_files"], 20);
  // The session's copy (one NRRD) holds the series' geometry and voxels exactly.
  const auto direct = io::readImage(dicom);
  const auto stored = io::readImage(s.resolve(ct->file));
  EXPECT_EQ(stored.size, direct.size);
  EXPECT_TRUE(stored.spacing.isApprox(direct.spacing, 1e-9));
  EXPECT_TRUE(stored.origin.isApprox(direct.origin, 1e-9));
  EXPECT_TRUE(stored.direction.isApprox(direct.direction, 1e-12));
  EXPECT_EQ(stored.data, direct.data);
  EXPECT_EQ(ct->size_px, direct.size);
}

TEST(PatientData, BadInputIsRefusedSayingWhatToDoAndNothingIsLost) {
  MRSNS_REQUIRE_DATA(ct, kCt);
  MRSNS_REQUIRE_DATA(vertebrae, kVertebrae);
  MRSNS_REQUIRE_DATA(verse, "ct/verse/sub-verse004_seg-vert_msk.nii.gz");
  const auto dir = test::scratchDirectory("s");
  auto s = Session::create(dir / "session");
  const auto expectRefused = [&](const std::string& step, const Json& params, const std::string& says) {
    SCOPED_TRACE(step + " " + params.dump());
    try {
      (void)run(s, step, params);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  // Before the CT: every step on the patient's data names import-ct.
  expectRefused("import-label-map", {{"path", vertebrae.string()}}, "import the CT");
  expectRefused("plan-screw", {{"name", "L1 left"}, {"entry", "0,0,0"}, {"target", "1,1,1"}}, "import-ct");
  // A label map is not a CT.
  expectRefused("import-ct", {{"path", vertebrae.string()}}, "it is a label map, not a CT");
  // An image that is not in Hounsfield units (an MR-like range, 0..1200).
  ImageVolume mr;
  mr.size = {20, 20, 10};
  mr.pixel_type = PixelType::UInt16;
  mr.data.resize(mr.byteCount());
  for (std::size_t i = 0; i < mr.voxelCount(); ++i) {
    const auto v = static_cast<std::uint16_t>((i * 37) % 1200);
    std::memcpy(mr.data.data() + 2 * i, &v, 2);
  }
  io::writeImage(mr, dir / "t1.nrrd");
  expectRefused("import-ct", {{"path", (dir / "t1.nrrd").string()}}, "not Hounsfield units");
  // A DICOM that says it is not a CT: the NEMA slice relabelled as an MR series.
  {
    MRSNS_REQUIRE_DATA(small, "ct/nema/CT_small.dcm");
    MRSNS_REQUIRE_TOOL(gdcmanon, "gdcmanon");
    std::filesystem::create_directories(dir / "mr");
    const auto relabel = test::runProgram(gdcmanon, {"--dumb", "--replace", "0008,0060=MR", "--replace",
                                                     "0008,0016=1.2.840.10008.5.1.4.1.1.4", "--replace",
                                                     "0008,103e=T1 axial", "-i", small.string(), "-o",
                                                     (dir / "mr" / "mr.dcm").string()});
    ASSERT_EQ(relabel.exit_code, 0) << relabel.err;
    expectRefused("import-ct", {{"path", (dir / "mr").string()}}, "is a MR series (\"T1 axial\"), not a CT");
  }
  EXPECT_FALSE(s.ct().has_value());

  ASSERT_TRUE(run(s, "import-ct", {{"path", ct.string()}}).ok);
  // A second CT in the same session, and a label map of another patient's image (VerSe, 1x1x2 mm).
  expectRefused("import-ct", {{"path", ct.string()}}, "already has a CT");
  expectRefused("import-label-map", {{"path", verse.string()}}, "does not overlap the session's CT");
  // An empty segmentation.
  auto empty = io::readImage(vertebrae);
  std::fill(empty.data.begin(), empty.data.end(), std::byte{0});
  io::writeImage(empty, dir / "empty.nii.gz");
  expectRefused("import-label-map", {{"path", (dir / "empty.nii.gz").string()}}, "holds no label");
  EXPECT_TRUE(s.labelMaps().empty());
  ASSERT_TRUE(run(s, "import-label-map", {{"path", vertebrae.string()}}).ok);
  // A label the map does not hold (L6 is absent: empty), named with the ones it holds.
  expectRefused("make-models", {{"labels", "L6"}}, "the labels present are vertebrae_S1 (26)");
  ASSERT_TRUE(run(s, "make-models", {{"labels", "L1"}}).ok);
  // A screw outside the image: refused, the plan as it was.
  ASSERT_TRUE(run(s, "plan-screw",
                  {{"name", "L1 left"}, {"entry", point(kPlans[0].entry)}, {"target", point(kPlans[0].target)},
                   {"diameter_mm", 6.0}, {"length_mm", 45.0}})
                  .ok);
  const Json plan = Json(s.plans());
  expectRefused("plan-screw", {{"name", "far"}, {"entry", "0,0,1000"}, {"target", "0,0,1040"}},
                "outside the CT: plan the screw inside the patient's image");
  expectRefused("plan-screw", {{"name", "L1 left"}, {"target", "25.5,-84,382"}}, "its entry on its target");
  expectRefused("plan-screw", {{"name", "L1 left"}, {"diameter_mm", -1.0}}, "diameter_mm must be in (0, 15]");
  EXPECT_EQ(Json(s.plans()), plan) << "the plan is unchanged";
  // A shape model in another frame than the CT (scalismo's example, far from this abdomen) is refused; placed
  // with a ModelToCT it is taken, and its mean becomes a soft-tissue model.
  if (const auto model = findDataFile("ssm/scalismo/model.h5")) {
    expectRefused("shape-model", {{"path", model->string()}}, "is in another frame than the CT");
    EXPECT_FALSE(s.shapeModel().has_value());
  } else if (test::missingDataFails()) {
    FAIL() << test::missingDataMessage("ssm/scalismo/model.h5");
  }
}

TEST(PatientData, TheShapeModelIsPlacedInTheCtAndItsMeanShown) {
  MRSNS_REQUIRE_DATA(ct, kCt);
  MRSNS_REQUIRE_DATA(model, "ssm/scalismo/model.h5");
  auto s = Session::create(test::scratchDirectory("s") / "session");
  ASSERT_TRUE(run(s, "import-ct", {{"path", ct.string()}}).ok);
  // A ModelToCT that brings the model's mean to the CT's centre (a user's placement of a model built elsewhere).
  const auto statismo = io::readStatismoModel(model);
  const Eigen::Vector3d mean_centre =
      Eigen::Map<const PointsN3>(statismo.mean.data(), statismo.pointCount(), 3).colwise().mean().transpose();
  const auto image = io::readImage(ct);
  const Eigen::Vector3d ct_centre = image.indexToPhysical(
      0.5 * Eigen::Vector3d(image.size[0] - 1, image.size[1] - 1, image.size[2] - 1));
  Eigen::Matrix4d ct_T_model = Eigen::Matrix4d::Identity();
  ct_T_model.block<3, 1>(0, 3) = ct_centre - mean_centre;
  Json matrix = Json::array();
  for (int i = 0; i < 16; ++i) matrix.push_back(ct_T_model(i / 4, i % 4));
  const auto r = run(s, "shape-model", {{"path", model.string()}, {"model_to_ct", matrix}});
  ASSERT_TRUE(r.ok) << r.summary;
  const auto entry = s.shapeModel();
  ASSERT_TRUE(entry.has_value());
  EXPECT_EQ(entry->components, static_cast<int>(statismo.modeCount()));
  EXPECT_EQ(entry->points, static_cast<std::size_t>(statismo.pointCount()));
  EXPECT_TRUE(entry->ct_T_model.isApprox(ct_T_model));
  EXPECT_TRUE(fs::exists(s.resolve(entry->file)));
  const auto mean = s.model(entry->mean_model);
  ASSERT_TRUE(mean.has_value());
  EXPECT_EQ(mean->role, ModelRole::SoftTissue);
  const auto mesh = io::readMesh(s.resolve(mean->file));
  EXPECT_EQ(mesh.vertexCount(), statismo.pointCount()) << "the headset moves these vertices: none dropped";
  EXPECT_LT((vertexCentroid(mesh) - ct_centre).norm(), 1e-3);
}

TEST(PatientData, TheFiducialScrewsOfThePhantomAreFoundOnTheirLabelAsOnTheirMetal) {
  auto s = Session::create(test::scratchDirectory("s") / "session");
  ASSERT_TRUE(run(s, "import-phantom", {{"spacing_mm", 1.0}}).ok);
  const auto by_metal = s.fiducials();
  ASSERT_TRUE(by_metal.has_value());
  ASSERT_EQ(by_metal->points.size(), 8u);
  const auto by_label = run(s, "find-fiducials", {{"source", "label"}});
  ASSERT_TRUE(by_label.ok) << by_label.summary;
  EXPECT_EQ(by_label.figures["label"]["value"], 92);
  const auto found = s.fiducials();
  ASSERT_EQ(found->points.size(), 8u);
  // The same screws: each within a voxel of the other way's, and of where the phantom's screw enters the bone.
  registration::PhantomOptions options;
  options.spacing_mm = 1.0;
  const auto phantom = registration::generateCervicalPhantom(options);
  for (const auto& truth : phantom.fiducials_truth.points) {
    double metal = 1e9, label = 1e9;
    for (const auto& f : by_metal->points) metal = std::min(metal, (f.position_ct - truth.position).norm());
    for (const auto& f : found->points) label = std::min(label, (f.position_ct - truth.position).norm());
    EXPECT_LT(metal, 1.0) << truth.label;
    EXPECT_LT(label, 1.0) << truth.label;
  }
  // Placed by hand, moved, removed.
  ASSERT_TRUE(run(s, "place-fiducial", {{"position", "1,2,3"}}).ok);
  EXPECT_EQ(s.fiducials()->points.back().label, "F-9");
  EXPECT_EQ(s.fiducials()->points.back().source, "placed");
  ASSERT_TRUE(run(s, "place-fiducial", {{"label", "F-9"}, {"position", "1,2,4"}}).ok);
  EXPECT_EQ(s.fiducials()->points.back().position_ct, Eigen::Vector3d(1, 2, 4));
  ASSERT_TRUE(run(s, "place-fiducial", {{"label", "F-9"}, {"remove", true}}).ok);
  EXPECT_EQ(s.fiducials()->points.size(), 8u);
  EXPECT_THROW((void)run(s, "place-fiducial", {{"position", "0,0,900"}}), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::workflow
