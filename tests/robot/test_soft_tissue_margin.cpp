// The supervisor's soft-tissue check on the drill's shaft and with the posterior's uncertainty: a surface
// the tip is far from but the shaft passes stops the arm; a surface outside the fixed margin but inside k
// standard deviations of it stops the arm; the same surface known exactly does not.
#include <gtest/gtest.h>

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/robot/safety_supervisor.h"
#include "robot_test_scene.h"

namespace mrsns::robot {
namespace {

// A supervisor advancing along +z from the origin, with a live arm.
struct Advancing {
  SafetySupervisor sup;
  SupervisorInputs in;
  explicit Advancing(const SupervisorLimits& limits) : sup(limits) {
    in.arm.connected = true;
    in.arm.mode = RobotMode::Running;
    in.axis_plan = Eigen::Vector3d::UnitZ();
    sup.setPlannedAxis({Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), true});
    EXPECT_TRUE(sup.enable(1, 0));
    EXPECT_TRUE(sup.startAligning(2, 0));
    EXPECT_TRUE(sup.aligned(3, 0));
  }
  SupervisorDecision tick() {
    ++in.cycle;
    ++in.arm.cycle;
    return sup.tick(in);
  }
};

std::shared_ptr<SoftTissueSurface> surface(const TriangleMesh& mesh, double sd_mm) {
  auto s = std::make_shared<SoftTissueSurface>();
  s->surface = std::make_shared<MeshLocator>(mesh);
  s->face_sd_mm.assign(static_cast<std::size_t>(mesh.faces.rows()), sd_mm);
  s->max_sd_mm = sd_mm;
  return s;
}

TEST(SoftTissueMargin, TheShaftBehindTheTipIsKeptOutOfTheMargin) {
  SupervisorLimits limits;
  limits.soft_tissue_margin_mm = 2.0;
  limits.drill_shaft_length_mm = 100.0;
  // A 2 mm box whose face is 1 mm beside the shaft, 50 mm behind the tip: the tip is 50 mm away.
  const TriangleMesh box = test::boxMesh(Eigen::Vector3d(3.0, 0.0, -50.0), 2.0);
  {
    Advancing a(limits);
    a.sup.setSoftTissue(surface(box, 0.0));
    const auto d = a.tick();
    EXPECT_EQ(d.reason, StopReason::SoftTissueMargin);
    EXPECT_EQ(d.stop, StopCommand::ProtectiveStop);
    EXPECT_NEAR(d.soft_tissue_distance_mm, 1.0, 1e-9);
    ASSERT_FALSE(a.sup.transitions().empty());
    EXPECT_NE(a.sup.transitions().back().detail.find("shaft"), std::string::npos) << a.sup.transitions().back().detail;
  }
  {
    // The tip alone (the check before the shaft was known) passes: the case the shaft check exists for.
    limits.drill_shaft_length_mm = 0.0;
    Advancing a(limits);
    a.sup.setSoftTissue(surface(box, 0.0));
    EXPECT_EQ(a.tick().reason, StopReason::None);
  }
  {
    // A shaft shorter than the distance to the box passes too.
    limits.drill_shaft_length_mm = 40.0;
    Advancing a(limits);
    a.sup.setSoftTissue(surface(box, 0.0));
    EXPECT_EQ(a.tick().reason, StopReason::None);
  }
}

TEST(SoftTissueMargin, NoPointOfTheShaftIsMissedBetweenTwoCheckPoints) {
  // A thin plate (0.2 mm) across the shaft between two check points 5 mm apart would slip through a check at
  // the points alone: half a step is added to the margin.
  SupervisorLimits limits;
  limits.soft_tissue_margin_mm = 0.5;
  limits.drill_shaft_length_mm = 50.0;
  limits.drill_shaft_step_mm = 5.0;
  TriangleMesh plate = test::boxMesh(Eigen::Vector3d(0.0, 0.0, -22.5), 1.0);
  for (Eigen::Index i = 0; i < plate.vertices.rows(); ++i) {
    const double z = plate.vertices(i, 2) > -22.5 ? -22.4 : -22.6;
    plate.vertices.row(i) = Eigen::RowVector3d(plate.vertices(i, 0) + 1.3, plate.vertices(i, 1), z);
  }
  // The plate's edge is 0.3 mm from the shaft (inside the 0.5 mm margin) and 2.4 mm from either check point
  // (z = -20, -25).
  Advancing a(limits);
  a.sup.setSoftTissue(surface(plate, 0.0));
  EXPECT_EQ(a.tick().reason, StopReason::SoftTissueMargin);
}

TEST(SoftTissueMargin, TheMarginGrowsByKStandardDeviationsOfTheSurface) {
  SupervisorLimits limits;
  limits.soft_tissue_margin_mm = 2.0;
  limits.soft_tissue_margin_sd = 2.0;
  // The surface 3 mm from the tip: outside the 2 mm margin, inside 2 mm + 2 x 1 mm.
  const TriangleMesh box = test::boxMesh(Eigen::Vector3d(5.0, 0.0, 0.0), 2.0);
  for (const double sd : {0.0, 0.4, 0.6, 1.0}) {
    Advancing a(limits);
    a.sup.setSoftTissue(surface(box, sd));
    const bool inside = 3.0 < 2.0 + 2.0 * sd;
    EXPECT_EQ(a.tick().reason, inside ? StopReason::SoftTissueMargin : StopReason::None) << "sd " << sd;
  }
  // Only the standard deviation of the face the drill is near counts.
  auto mixed = surface(box, 0.0);
  mixed->max_sd_mm = 5.0;
  const auto& normals = mixed->surface->faceNormals();
  for (std::size_t f = 0; f < mixed->face_sd_mm.size(); ++f) {
    if (normals(static_cast<Eigen::Index>(f), 0) > 0.5) mixed->face_sd_mm[f] = 5.0;  // the far side
  }
  Advancing a(limits);
  a.sup.setSoftTissue(mixed);
  EXPECT_EQ(a.tick().reason, StopReason::None);
}

TEST(SoftTissueMargin, StandardDeviationsMustBeOnePerFace) {
  SafetySupervisor sup;
  auto s = surface(test::boxMesh(Eigen::Vector3d::Zero(), 1.0), 1.0);
  s->face_sd_mm.pop_back();
  EXPECT_THROW(sup.setSoftTissue(std::shared_ptr<const SoftTissueSurface>(s)), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::robot
