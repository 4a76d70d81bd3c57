// The typed session document (session.json version 2): every entry round
// trips, calibrations and registrations follow the step records, and a
// version-1 session is upgraded with nothing lost.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/workflow/session.h"
#include "test_data.h"

namespace mrsns::workflow {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

nlohmann::json matrixJson(const Eigen::Matrix4d& m) {
  nlohmann::json out = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) out.push_back(m(r, c));
  }
  return out;
}

Eigen::Matrix4d translation(double x, double y, double z) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<3, 1>(0, 3) = Eigen::Vector3d(x, y, z);
  return m;
}

TEST(SessionDocument, EveryTypedEntryRoundTripsThroughTheFile) {
  const auto dir = test::scratchDirectory("s") / "session";
  ImageEntry ct;
  ct.file = "ct/CT.nrrd";
  ct.name = "patient";
  ct.format = "dicom";
  ct.modality = "CT";
  ct.series_uid = "1.2.3";
  ct.size_px = {512, 512, 400};
  ct.spacing_mm = Eigen::Vector3d(0.7, 0.7, 1.25);
  ct.origin_mm = Eigen::Vector3d(-180.0, -150.5, 20.25);
  ct.direction = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  ct.pixel_type = "int16";
  ct.value_min = -1024.0;
  ct.value_max = 3071.0;
  ct.provenance.source = "file";
  ct.provenance.file = "/data/patient/dicom";
  ct.provenance.time = "2026-12-03T10:00:00Z";
  LabelMapEntry labels;
  labels.id = "labels";
  labels.file = "labels/labels.nrrd";
  labels.scheme = "totalsegmentator";
  labels.placement = "embedded";
  labels.labels = {{31, "vertebrae_L1", 2143, "bone"}, {52, "aorta", 997, "vessel"}};
  ModelEntry model;
  model.id = "L1";
  model.name = "L1";
  model.file = "models/L1.vtp";
  model.hmd_file = "models/hmd/L1.vtp";
  model.role = ModelRole::Bone;
  model.color = Eigen::Vector3d(0.9, 0.8, 0.7);
  model.opacity = 0.75;
  model.visible = false;
  model.vertebra = "L1";
  model.label_map = "labels";
  model.label = 31;
  model.triangles = 4128;
  model.hmd_triangles = 2000;
  model.volume_ml = 56.43;
  model.voxel_volume_ml = 57.86;
  model.volume_tolerance_ml = 18.3;
  model.provenance.simulated = true;
  ModelEntry threshold = model;
  threshold.id = "bone";
  threshold.label_map.clear();
  threshold.threshold_hu = 250.0;
  ShapeModelEntry shape;
  shape.file = "shape_model/model.h5";
  shape.ct_T_model = translation(1, 2, 3);
  shape.components = 19;
  shape.points = 20000;
  shape.mean_model = "soft-tissue-mean";
  FiducialSet fiducials;
  fiducials.file = "fiducials/Fiducials.mrk.json";
  fiducials.points = {{"F-1", {1, 2, 3}, "threshold", 0.9, {0, 1, 0}}, {"F-2", {4, 5, 6}, "placed"}};
  PlannedScrew screw;
  screw.name = "L1 left";
  screw.vertebra = "L1";
  screw.side = "left";
  screw.entry = Eigen::Vector3d(25.5, -84, 382);
  screw.target = Eigen::Vector3d(5.5, -134, 382);
  screw.diameter_mm = 6.0;
  screw.length_mm = 45.0;
  screw.figures = {{"breach", {{"max_breach_mm", 0.0}, {"grade", "A"}}}};
  {
    auto session = Session::create(dir);
    session.setCt(ct);
    session.putLabelMap(labels);
    session.putModels({model, threshold});
    session.setShapeModel(shape);
    session.setFiducials(fiducials);
    session.setPlans({screw});
  }
  const auto s = Session::open(dir);
  ASSERT_TRUE(s.ct().has_value());
  EXPECT_EQ(nlohmann::json(*s.ct()), nlohmann::json(ct));
  EXPECT_TRUE(s.ct()->direction.isApprox(ct.direction, 1e-15));
  ASSERT_EQ(s.labelMaps().size(), 1u);
  EXPECT_EQ(nlohmann::json(s.labelMaps()[0]), nlohmann::json(labels));
  ASSERT_EQ(s.models().size(), 2u);
  EXPECT_EQ(nlohmann::json(*s.model("L1")), nlohmann::json(model));
  EXPECT_FALSE(s.model("L1")->visible);
  EXPECT_TRUE(s.model("L1")->provenance.simulated);
  EXPECT_EQ(s.model("bone")->threshold_hu, 250.0);
  EXPECT_TRUE(std::isnan(s.model("L1")->threshold_hu)) << "no threshold: absent, not 0";
  EXPECT_EQ(s.models(ModelRole::Bone).size(), 2u);
  EXPECT_TRUE(s.models(ModelRole::Vessel).empty());
  EXPECT_EQ(s.freeModelId("L1"), "L1-2");
  EXPECT_EQ(nlohmann::json(*s.shapeModel()), nlohmann::json(shape));
  EXPECT_EQ(nlohmann::json(*s.fiducials()), nlohmann::json(fiducials));
  EXPECT_TRUE(std::isnan(s.fiducials()->points[1].confidence)) << "a placed point has no confidence";
  ASSERT_EQ(s.plans().size(), 1u);
  EXPECT_EQ(nlohmann::json(s.plans()[0]), nlohmann::json(screw));
  EXPECT_EQ(s.plan("L1 left")->figures["breach"]["grade"], "A");
  EXPECT_FALSE(s.plan("L2 left").has_value());
}

TEST(SessionDocument, CalibrationsFollowTheLatestSuccessfulStep) {
  auto session = Session::create(test::scratchDirectory("s") / "session");
  const auto record = [&](const std::string& step, const std::string& status, const Eigen::Matrix4d& m,
                          bool simulated = false) {
    session.recordStep(step, {{"status", status},
                              {"summary", step + " " + status},
                              {"figures", {{"transforms", {{"StylusTipToStylus", matrixJson(m)}}},
                                           {"rms_mm", 0.2},
                                           {"simulated", simulated}}},
                              {"outputs", {step + "/StylusTipToStylus.tfm", step + "/StylusPivot.mhd"}}});
  };
  record("pivot-calibration", "ok", translation(0, 0, -160), true);
  auto t = session.transform("StylusTipToStylus");
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->kind, "calibration");
  EXPECT_EQ(t->provenance.step, "pivot-calibration");
  EXPECT_TRUE(t->provenance.simulated);
  EXPECT_EQ(t->file, "pivot-calibration/StylusTipToStylus.tfm");
  EXPECT_EQ(t->provenance.quality["rms_mm"], 0.2);
  EXPECT_TRUE(t->matrix.isApprox(translation(0, 0, -160)));
  // A later step giving the same transform wins (the spin's whole tip frame).
  record("spin-calibration", "ok", translation(0, 0, -161));
  EXPECT_EQ(session.transform("StylusTipToStylus")->provenance.step, "spin-calibration");
  // Run again and failed: its transform is never used, and the pivot's stands again.
  record("spin-calibration", "failed", translation(9, 9, 9));
  t = session.transform("StylusTipToStylus");
  ASSERT_TRUE(t.has_value());
  EXPECT_EQ(t->provenance.step, "pivot-calibration");
  EXPECT_TRUE(t->matrix.isApprox(translation(0, 0, -160)));
  // A registration lands among the registrations.
  session.recordStep("registration",
                     {{"status", "ok"}, {"figures", {{"transforms", {{"CTToPatient", matrixJson(translation(1, 2, 3))}}}}}});
  ASSERT_EQ(session.registrations().size(), 1u);
  EXPECT_EQ(session.registrations()[0].name, "CTToPatient");
  EXPECT_EQ(session.calibrations().size(), 1u);
  // Every recording a step wrote is listed, a failed step's too (it is what the user has on disk).
  const auto recordings = session.recordings();
  EXPECT_EQ(recordings.size(), 2u);
  for (const auto& r : recordings) EXPECT_EQ(r.kind, "tracking") << r.file;
  // What was derived is in the file: a reopened session answers the same.
  const auto reopened = Session::open(session.folder());
  EXPECT_EQ(reopened.transform("StylusTipToStylus")->provenance.step, "pivot-calibration");
}

TEST(SessionDocument, AVersionOneSessionIsUpgradedWithNothingLost) {
  const auto dir = test::scratchDirectory("s") / "v1";
  fs::create_directories(dir / "imported");
  fs::create_directories(dir / "registration" / "models");
  // A mesh the version-1 GUI imported, and a registration's model of the phantom.
  ImageVolume box;
  box.size = {6, 6, 6};
  box.spacing = Eigen::Vector3d::Ones();
  box.pixel_type = PixelType::UInt8;
  box.data.assign(box.voxelCount(), std::byte{0});
  for (int k = 1; k < 5; ++k) {
    for (int j = 1; j < 5; ++j) {
      for (int i = 1; i < 5; ++i) box.data[box.linearIndex(i, j, k)] = std::byte{1};
    }
  }
  const auto mesh = registration::meshLabelMap(box).meshes.at(0).mesh;
  io::writeMesh(mesh, dir / "imported" / "carotid_artery.stl");
  io::writeMesh(mesh, dir / "registration" / "models" / "C5.vtp");
  const nlohmann::json v1 = {
      {"version", 1},
      {"created", "2026-11-20T08:00:00Z"},
      {"inputs", {{"tracker", "simulated"}}},
      {"steps",
       {{"pivot-calibration",
         {{"status", "ok"},
          {"time", "2026-11-20T08:10:00Z"},
          {"figures", {{"transforms", {{"StylusTipToStylus", matrixJson(translation(0, 0, -160))}}}}},
          {"outputs", {"pivot-calibration/StylusPivot.mhd"}}}},
        {"import-mesh", {{"summary", "imported carotid_artery.stl"}, {"outputs", {"imported/carotid_artery.stl"}}}},
        {"registration",
         {{"status", "ok"},
          {"time", "2026-11-20T08:20:00Z"},
          {"figures",
           {{"transforms", {{"CTToPatient", matrixJson(translation(1, 2, 3))}}},
            {"models", {{{"file", "registration/models/C5.vtp"}, {"layer", "vertebrae"}}}},
            {"paths", {{{"name", "C5 left"}, {"entry_ct", {1, 2, 3}}, {"target_ct", {4, 5, 6}}}}}}}}}}},
      {"log", {{{"time", "2026-11-20T08:00:00Z"}, {"level", "info"}, {"message", "created"}}}}};
  const std::string original = v1.dump(2);
  test::writeBytes(dir / "session.json", original);

  const auto s = Session::open(dir);
  EXPECT_EQ(s.openedVersion(), 1);
  EXPECT_EQ(s.state()["version"], kSessionVersion);
  // The original is kept byte for byte, and the upgraded file is on disk.
  ASSERT_TRUE(fs::exists(dir / "session.v1.json"));
  EXPECT_EQ(slurp(dir / "session.v1.json"), original);
  EXPECT_EQ(nlohmann::json::parse(slurp(dir / "session.json"))["version"], kSessionVersion);
  // Every step record, the inputs and the log stay.
  for (const char* step : {"pivot-calibration", "import-mesh", "registration"}) {
    EXPECT_EQ(s.step(step), v1["steps"][step]) << step;
  }
  EXPECT_EQ(s.state()["inputs"], v1["inputs"]);
  ASSERT_EQ(s.state()["log"].size(), 2u);
  EXPECT_NE(s.state()["log"][1]["message"].get<std::string>().find("upgraded from session version 1"),
            std::string::npos);
  // What the typed document can tell from them.
  ASSERT_TRUE(s.transform("StylusTipToStylus").has_value());
  EXPECT_TRUE(s.transform("StylusTipToStylus")->matrix.isApprox(translation(0, 0, -160)));
  ASSERT_TRUE(s.transform("CTToPatient").has_value());
  const auto vessel = s.model("carotid_artery");
  ASSERT_TRUE(vessel.has_value());
  EXPECT_EQ(vessel->role, ModelRole::Vessel);
  EXPECT_EQ(vessel->provenance.source, "migration");
  const auto c5 = s.model("C5");
  ASSERT_TRUE(c5.has_value());
  EXPECT_EQ(c5->role, ModelRole::Bone);
  ASSERT_EQ(s.plans().size(), 1u);
  EXPECT_EQ(s.plans()[0].name, "C5 left");
  EXPECT_EQ(s.plans()[0].side, "left");
  EXPECT_TRUE(s.plans()[0].target.isApprox(Eigen::Vector3d(4, 5, 6)));
  EXPECT_EQ(s.recordings().size(), 1u);
  // Opened again, it is a version-2 session: no second upgrade, no second backup.
  const auto again = Session::open(dir);
  EXPECT_EQ(again.openedVersion(), kSessionVersion);
  EXPECT_FALSE(fs::exists(dir / "session.v1-2.json"));
}

TEST(SessionDocument, DamagedOrFutureDocumentsAreRefusedWithTheirPlace) {
  const auto dir = test::scratchDirectory("s") / "bad";
  fs::create_directories(dir);
  test::writeBytes(dir / "session.json", R"({"version": 3, "steps": {}})");
  try {
    (void)Session::open(dir);
    FAIL() << "opened a future version";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("version 3"), std::string::npos) << e.what();
  }
  test::writeBytes(dir / "session.json",
                   R"({"version": 2, "steps": {}, "models": [{"id": "L1", "role": "bones", "file": "m.vtp"}]})");
  try {
    (void)Session::open(dir);
    FAIL() << "opened a model with an unknown role";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bones"), std::string::npos) << e.what();
  }
  test::writeBytes(dir / "session.json",
                   R"({"version": 2, "steps": {}, "plans": [{"name": "L1 left", "entry": [1, 2]}]})");
  EXPECT_THROW((void)Session::open(dir), FormatError);
}

TEST(SessionDocument, ANewCtSetsTheOldPatientDataAsideWithoutDeletingIt) {
  auto session = Session::create(test::scratchDirectory("s") / "session");
  ImageEntry ct;
  ct.file = "ct/old.nrrd";
  session.setCt(ct);
  ModelEntry m;
  m.id = "L1";
  m.file = "models/L1.vtp";
  session.putModel(m);
  PlannedScrew screw;
  screw.name = "L1 left";
  session.setPlans({screw});
  std::filesystem::create_directories(session.resolve("models"));
  std::filesystem::create_directories(session.resolve("plans"));
  std::ofstream(session.resolve("models/L1.vtp")) << "the old patient's L1";
  std::ofstream(session.resolve("plans/Plan.mrk.json")) << "the old plan";
  session.setAsidePatientData("a new CT");
  EXPECT_FALSE(session.ct().has_value());
  EXPECT_TRUE(session.models().empty());
  EXPECT_TRUE(session.plans().empty());
  const auto& aside = session.state()["set_aside"];
  ASSERT_EQ(aside.size(), 1u);
  EXPECT_EQ(aside[0]["reason"], "a new CT");
  EXPECT_EQ(aside[0]["models"][0]["id"], "L1");
  EXPECT_EQ(aside[0]["plans"][0]["name"], "L1 left");
  EXPECT_EQ(aside[0]["images"][0]["file"], "ct/old.nrrd") << "a file that is not there is named as it was";
  // The files moved with their entries: the new patient's models/L1.vtp and plan cannot overwrite them.
  EXPECT_EQ(aside[0]["models"][0]["file"], "set_aside/1/models/L1.vtp");
  EXPECT_EQ(aside[0]["plan_file"], "set_aside/1/plans/Plan.mrk.json");
  EXPECT_FALSE(std::filesystem::exists(session.resolve("models/L1.vtp")));
  std::ofstream(session.resolve("models/L1.vtp")) << "the new patient's L1";
  std::ifstream old_model(session.resolve("set_aside/1/models/L1.vtp"));
  std::string text;
  std::getline(old_model, text);
  EXPECT_EQ(text, "the old patient's L1");
  // Reopened, the record is the same.
  EXPECT_EQ(Session::open(session.folder()).state()["set_aside"], aside);
}

TEST(SessionDocument, StructureRolesFromLabelNames) {
  EXPECT_EQ(structureRole("vertebrae_L1"), ModelRole::Bone);
  EXPECT_EQ(structureRole("C5"), ModelRole::Bone);
  EXPECT_EQ(structureRole("rib_left_7"), ModelRole::Bone);
  EXPECT_EQ(structureRole("aorta"), ModelRole::Vessel);
  EXPECT_EQ(structureRole("inferior_vena_cava"), ModelRole::Vessel);
  EXPECT_EQ(structureRole("common_carotid_artery_left"), ModelRole::Vessel);
  EXPECT_EQ(structureRole("carotid_artery"), ModelRole::Vessel);
  EXPECT_EQ(structureRole("spinal_cord"), ModelRole::Neural) << "not a fiducial although it holds 'pin'";
  EXPECT_EQ(structureRole("fiducial_screws"), ModelRole::Fiducial);
  EXPECT_EQ(structureRole("iliopsoas_left"), ModelRole::SoftTissue);
  EXPECT_EQ(structureRole("label_7"), ModelRole::Other);
  EXPECT_EQ(vertebraName("vertebrae_T12"), "T12");
  EXPECT_EQ(vertebraName("L6"), "L6");
  EXPECT_EQ(vertebraName("L7"), "");
  EXPECT_EQ(vertebraName("liver"), "");
  EXPECT_THROW((void)modelRoleFromName("bones"), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::workflow
