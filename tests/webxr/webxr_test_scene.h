#pragma once
// A small hologram scene for the WebXR tests: a box "Vertebra" and a thin box
// "Screw" in the patient's frame, tracked by a patient reference, shown in
// the hologram frame; and the service's options with the page from the
// source tree, Debian's three.js and a certificate made for the test.
#include <Eigen/Geometry>
#include <memory>

#include "mrsns/core/mesh.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/webxr/tls_certificate.h"
#include "mrsns/webxr/webxr_hologram_service.h"

namespace mrsns::test {

inline TriangleMesh boxMesh(const Eigen::Vector3d& half, const Eigen::Vector3d& center) {
  TriangleMesh mesh;
  mesh.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.row(i) = (center + Eigen::Vector3d((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                                                     (i & 4) ? half.z() : -half.z()))
                               .transpose();
  }
  mesh.faces.resize(12, 3);
  mesh.faces << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7,
      5;
  return mesh;
}

struct WebXrTestScene {
  std::shared_ptr<TransformRepository> repository = std::make_shared<TransformRepository>();
  std::vector<tracking::HologramModel> models;
  Eigen::Isometry3d tracker_T_hologram = Eigen::Isometry3d::Identity();

  /// Moves the patient (pose `i` of a fixed sequence); the Vertebra's hologram_T_model it should be shown at.
  Eigen::Matrix4d moveVertebra(int i) {
    Eigen::Isometry3d tracker_T_patient = Eigen::Isometry3d::Identity();
    tracker_T_patient.translate(Eigen::Vector3d(10.0 + 2.0 * i, -5.0 + 1.5 * i, 400.0 - 3.0 * i));
    tracker_T_patient.rotate(Eigen::AngleAxisd(0.05 * i, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()));
    repository->setTransform("PatientToTracker", tracker_T_patient, TransformStatus::Ok, unixTimeSeconds());
    return (tracker_T_hologram.inverse() * tracker_T_patient).matrix();
  }
};

inline WebXrTestScene webXrTestScene() {
  WebXrTestScene scene;
  scene.tracker_T_hologram.translate(Eigen::Vector3d(0.0, 0.0, 350.0));
  scene.tracker_T_hologram.rotate(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()));
  scene.repository->setTransform("HologramToTracker", scene.tracker_T_hologram, TransformStatus::Ok,
                                 std::numeric_limits<double>::quiet_NaN(), true);
  scene.models.push_back({"Vertebra", boxMesh({20.0, 15.0, 10.0}, {0.0, 0.0, 0.0}), "Patient"});
  scene.models.push_back({"Screw", boxMesh({2.0, 2.0, 22.0}, {12.0, 0.0, 0.0}), "Patient"});
  return scene;
}

inline webxr::WebXrServiceOptions webXrServiceOptions(const std::filesystem::path& tls_dir) {
  webxr::WebXrServiceOptions options;
  options.server.port = 0;
  options.server.web_root = std::filesystem::path(MRSNS_TEST_SOURCE_DIR) / ".." / "resources" / "webxr";
  options.server.three_root = webxr::defaultThreeJsDirectory();
  options.server.certificate = webxr::ensureSelfSignedCertificate(tls_dir, {});
  options.server.pairing_code = webxr::makePairingCode();
  options.stream.hologram_frame = "Hologram";
  return options;
}

}  // namespace mrsns::test
