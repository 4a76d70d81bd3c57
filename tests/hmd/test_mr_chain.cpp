// The MR chain (paper 001 Eq. 1) through the transform repository, and Eq. 23.
#include <gtest/gtest.h>

#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/mr_chain.h"
#include "mrsns/tracking/unity_convention.h"

namespace mrsns::hmd {
namespace {

Eigen::Isometry3d pose(double a, double b, double c, double x, double y, double z) {
  Vector6d xi;
  xi << x, y, z, a, b, c;
  return se3Exp(xi);
}

struct Chain {
  Eigen::Isometry3d tracker_T_hologram = pose(0.1, 1.2, -0.3, 400, -100, 1800);
  Eigen::Isometry3d tracker_T_patient = pose(-0.5, 0.2, 2.9, -50, 30, 1500);
  Eigen::Isometry3d patient_T_preop = pose(0.05, -0.02, 0.1, 12, -7, 40);
  Eigen::Isometry3d preop_T_virtual = preopFromVirtualRasLps();
};

TEST(MrChain, RepositoryAnswersEquationOne) {
  const Chain c;
  TransformRepository repo;
  setMrChain(repo, c.tracker_T_hologram, c.tracker_T_patient, c.patient_T_preop, c.preop_T_virtual, 12.5);
  const auto p = hologramPose(repo);
  const Eigen::Isometry3d expected =
      c.tracker_T_hologram.inverse() * c.tracker_T_patient * c.patient_T_preop * c.preop_T_virtual;
  EXPECT_LT((p.hologram_T_virtual.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT(
      (hologramFromVirtual(c.tracker_T_hologram, c.tracker_T_patient, c.patient_T_preop, c.preop_T_virtual).matrix() -
       expected.matrix())
          .cwiseAbs()
          .maxCoeff(),
      1e-9);
  EXPECT_EQ(p.status, TransformStatus::Ok);
  EXPECT_DOUBLE_EQ(p.timestamp, 12.5);
  // Unity: left-handed metres, the tracking module's conversion (not a second copy).
  EXPECT_LT((p.hologram_T_virtual_unity - tracking::transformToUnity(expected.matrix())).cwiseAbs().maxCoeff(), 1e-12);
  // A point of the model lands at the same physical place either way.
  const Eigen::Vector3d v(10, 20, 30);
  const Eigen::Vector3d unity_point =
      (p.hologram_T_virtual_unity * Eigen::Vector4d(-0.010, 0.020, 0.030, 1.0)).head<3>();
  const Eigen::Vector3d mm_point = expected * v;
  EXPECT_LT((Eigen::Vector3d(-unity_point.x(), unity_point.y(), unity_point.z()) * 1000.0 - mm_point).norm(), 1e-9);
}

TEST(MrChain, RasLpsHandednessIsAProperRotation) {
  const auto T = preopFromVirtualRasLps();
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-15);
  EXPECT_TRUE(isRigid(T.matrix()));
  EXPECT_LT((T * Eigen::Vector3d(1, 2, 3) - Eigen::Vector3d(-1, -2, 3)).norm(), 1e-15);
}

TEST(MrChain, FusionErrorIsZeroWithTheTrueCalibrationAndMeasuresAnOffset) {
  const Chain c;
  const std::vector<Eigen::Vector3d> fiducials = {{0, 0, 0},  {50, 0, 0},  {0, 50, 0},
                                                  {0, 0, 50}, {30, 30, 0}, {-20, 10, 40}};
  const Eigen::Isometry3d patient_T_virtual = c.patient_T_preop * c.preop_T_virtual;
  const auto exact =
      hologramFromVirtual(c.tracker_T_hologram, c.tracker_T_patient, c.patient_T_preop, c.preop_T_virtual);
  EXPECT_LT(fusionRmsErrorMm(fiducials, exact, c.tracker_T_hologram, c.tracker_T_patient, patient_T_virtual), 1e-9);
  // A calibration off by 1.3 mm in translation shows every fiducial 1.3 mm off.
  Eigen::Isometry3d wrong = c.tracker_T_hologram;
  wrong.translation() += Eigen::Vector3d(1.3, 0, 0);
  const auto shown = hologramFromVirtual(wrong, c.tracker_T_patient, c.patient_T_preop, c.preop_T_virtual);
  EXPECT_NEAR(fusionRmsErrorMm(fiducials, shown, c.tracker_T_hologram, c.tracker_T_patient, patient_T_virtual), 1.3,
              1e-9);
  EXPECT_THROW(fusionRmsErrorMm({}, shown, c.tracker_T_hologram, c.tracker_T_patient, patient_T_virtual),
               InvalidArgumentError);
}

TEST(MrChain, MissingCalibrationIsAFrameError) {
  const Chain c;
  TransformRepository repo;
  repo.setTransform("Patient", "Tracker", c.tracker_T_patient);
  repo.setTransform("Preop", "Patient", c.patient_T_preop);
  repo.setTransform("Virtual", "Preop", c.preop_T_virtual);
  EXPECT_THROW(hologramPose(repo), FrameError);
}

}  // namespace
}  // namespace mrsns::hmd
