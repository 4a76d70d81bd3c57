// The hologram stream (Eq. 1 of paper 001) to an mrsns Client on loopback:
// meshes first, then transforms; STATUS on lost/regained tracking; Unity
// convention; client messages change nothing; playback reproduces the file.
#include <gtest/gtest.h>

#include <map>
#include <mutex>
#include <atomic>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/igtlink/image.h"
#include "mrsns/igtlink/ndarray.h"
#include "mrsns/igtlink/polydata_mesh.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/playback_source.h"
#include "mrsns/tracking/unity_convention.h"
#include "test_data.h"
#include "tracking_test_util.h"

namespace mrsns::tracking {
namespace {

using test::loopback;
using test::waitFor;

Eigen::Isometry3d randomPose(int seed) {
  std::srand(static_cast<unsigned>(seed));
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = Eigen::Quaterniond::UnitRandom().toRotationMatrix();
  p.translation() = Eigen::Vector3d::Random() * 500.0;
  return p;
}

// Frames of Eq. 1: Vertebra (Vir) -> Preop -> Patient -> Tracker <- Hologram.
struct Scene {
  std::shared_ptr<TransformRepository> repository = std::make_shared<TransformRepository>();
  Eigen::Isometry3d pre_T_vir = randomPose(1), pat_T_pre = randomPose(2), tra_T_pat = randomPose(3),
                    tra_T_hol = randomPose(4);
  Scene() {
    repository->setTransform("VertebraToPreop", pre_T_vir, TransformStatus::Ok, NAN, true);
    repository->setTransform("PreopToPatient", pat_T_pre, TransformStatus::Ok, NAN, true);
    repository->setTransform("PatientToTracker", tra_T_pat, TransformStatus::Ok, 100.0);
    repository->setTransform("HologramToTracker", tra_T_hol, TransformStatus::Ok, 100.0);
  }
  [[nodiscard]] Eigen::Isometry3d hol_T_vir() const { return tra_T_hol.inverse() * tra_T_pat * pat_T_pre * pre_T_vir; }
};

HologramStreamOptions streamOptions(igtlink::HeaderVersion version, bool unity = false,
                                    std::vector<std::string> forward = {}) {
  HologramStreamOptions options;
  options.version = version;
  options.unity = unity;
  options.forward_transforms = std::move(forward);
  return options;
}

std::vector<HologramModel> models() {
  return {{"C5", test::tetrahedron(), "Vertebra"}, {"C6", test::tetrahedron(20.0), "Vertebra"}};
}

TEST(HologramStream, MeshesFirstThenTransformsOfEquationOne) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, models());
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  for (int i = 0; i < 20; ++i) {
    scene.repository->setTransform("PatientToTracker", scene.tra_T_pat, TransformStatus::Ok, 100.0 + i);
    scene.repository->setTransform("HologramToTracker", scene.tra_T_hol, TransformStatus::Ok, 100.0 + i);
    streamer.update(0.0);
    streamer.update(0.0);  // no new data: nothing more sent
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_TRUE(waitFor([&] { return recorder.count("TRANSFORM") >= 40; }));
  server.stop();
  const auto received = recorder.messages();
  ASSERT_GE(received.size(), 42U);
  // Both meshes before any transform, intact.
  ASSERT_EQ(received[0].message.header.type, "POLYDATA");
  ASSERT_EQ(received[1].message.header.type, "POLYDATA");
  EXPECT_EQ(received[0].message.header.device_name, "C5");
  EXPECT_EQ(received[0].message.header.version, 2);
  EXPECT_EQ(received[0].message.metadataValue("Units"), "mm");
  const TriangleMesh mesh = igtlink::meshFromPolyData(*received[1].message.as<igtlink::PolyDataContent>());
  EXPECT_TRUE(mesh.vertices.isApprox(test::tetrahedron(20.0).vertices, 1e-6));
  EXPECT_EQ(mesh.faces, test::tetrahedron().faces);
  const Eigen::Isometry3d expected = scene.hol_T_vir();
  for (std::size_t i = 2; i < received.size(); ++i) {
    const auto& m = received[i].message;
    ASSERT_EQ(m.header.type, "TRANSFORM") << i;
    EXPECT_TRUE(test::equalAsFloat32(m.as<igtlink::TransformContent>()->matrix, expected.matrix())) << i;
    // The chain's (oldest tracked edge's) timestamp: update k sends 100 + k for both models.
    EXPECT_NEAR(m.header.timestampSeconds(), 100.0 + static_cast<double>((i - 2) / 2), 1e-9);
  }
  const auto stats = streamer.stats();
  EXPECT_EQ(stats.meshes_queued, 2U);
  EXPECT_EQ(stats.transforms_queued, 40U);
}

TEST(HologramStream, StatusWhenTrackingIsLostAndWhenItComesBack) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, {models()[0]}, streamOptions(igtlink::HeaderVersion::kV1));
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  streamer.update(0.0);
  scene.repository->setStatus("Patient", "Tracker", TransformStatus::Invalid, 101.0);
  streamer.update(0.0);
  streamer.update(0.0);  // still lost: no second STATUS, no TRANSFORM
  scene.repository->setTransform("PatientToTracker", scene.tra_T_pat, TransformStatus::Ok, 102.0);
  streamer.update(0.0);
  ASSERT_TRUE(waitFor([&] { return recorder.size() >= 5; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  server.stop();
  const auto received = recorder.messages();
  std::vector<std::string> sequence;
  for (const auto& r : received) {
    std::string entry = r.message.header.type;
    if (const auto* status = r.message.as<igtlink::StatusContent>()) entry += ":" + status->error_name;
    sequence.push_back(entry);
  }
  EXPECT_EQ(sequence, (std::vector<std::string>{"POLYDATA", "TRANSFORM", "STATUS:TrackingLost", "STATUS:TrackingOk",
                                                "TRANSFORM"}));
  EXPECT_EQ(received[2].message.as<igtlink::StatusContent>()->code,
            static_cast<std::uint16_t>(igtlink::StatusCode::kNotReady));
  EXPECT_EQ(received[1].message.header.version, 1);
}

TEST(HologramStream, ClientMessagesChangeNothing) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, models());
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1 && recorder.client().connected(); }));
  const auto edges_before = scene.repository->edges();
  // An HMD client tries to move a model, re-register, send a mesh and commands.
  Eigen::Isometry3d moved = Eigen::Isometry3d::Identity();
  moved.translation() = Eigen::Vector3d(50, 0, 0);
  const std::vector<igtlink::Message> attempts = {
      igtlink::makeMessage("C5", igtlink::TransformContent::fromIsometry(moved)),
      igtlink::makeMessage("PreopToPatient", igtlink::TransformContent::fromIsometry(moved)),
      igtlink::makeMessage("PatientToTracker", igtlink::TransformContent::fromIsometry(moved)),
      igtlink::makeMessage("C5", igtlink::polyDataFromMesh(test::tetrahedron(99.0))),
      igtlink::makeMessage("CMD", igtlink::StringContent{igtlink::kEncodingUsAscii, "MoveRobot"}),
      igtlink::makeMessage("GET_POLYDATA", "C5", igtlink::GetRequest{}),
  };
  for (const auto& m : attempts) ASSERT_TRUE(recorder.client().send(m, igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return streamer.stats().client_messages_ignored == attempts.size(); }));
  streamer.update(0.0);
  ASSERT_TRUE(waitFor([&] { return recorder.count("TRANSFORM") == 2; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  server.stop();
  // The repository is untouched, edge by edge ...
  const auto edges_after = scene.repository->edges();
  ASSERT_EQ(edges_after.size(), edges_before.size());
  for (std::size_t i = 0; i < edges_before.size(); ++i) {
    EXPECT_EQ(edges_after[i].from, edges_before[i].from);
    EXPECT_TRUE(edges_after[i].to_T_from.matrix() == edges_before[i].to_T_from.matrix());
    EXPECT_EQ(edges_after[i].status, edges_before[i].status);
  }
  // ... and the client got exactly the unchanged stream: 2 meshes, 2 transforms of Eq. 1.
  const auto received = recorder.messages();
  ASSERT_EQ(received.size(), 4U);
  EXPECT_EQ(received[0].message.header.type, "POLYDATA");
  EXPECT_EQ(received[1].message.header.type, "POLYDATA");
  const TriangleMesh mesh = igtlink::meshFromPolyData(*received[0].message.as<igtlink::PolyDataContent>());
  EXPECT_TRUE(mesh.vertices.isApprox(test::tetrahedron().vertices, 1e-6));
  for (std::size_t i = 2; i < 4; ++i) {
    EXPECT_TRUE(
        test::equalAsFloat32(received[i].message.as<igtlink::TransformContent>()->matrix, scene.hol_T_vir().matrix()));
  }
}

TEST(HologramStream, OnlyAConfirmationReachesItsCallbackAndPromptsReachLateHeadsets) {
  Scene scene;
  igtlink::Server server(loopback());
  std::atomic<int> confirmations{0};
  std::string last;
  std::mutex last_mutex;
  auto options = streamOptions(igtlink::HeaderVersion::kV2);
  options.on_confirmation = [&](igtlink::ClientId, const std::string& text) {
    std::lock_guard lock(last_mutex);
    last = text;
    confirmations.fetch_add(1);
  };
  HologramStreamer streamer(server, scene.repository, {models()[0]}, options);
  server.start();
  streamer.setPrompt("line up the cube");
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1 && recorder.client().connected(); }));
  // The prompt set before the headset came is sent to it on connection.
  ASSERT_TRUE(waitFor([&] { return recorder.count("STRING") == 1; }));
  const std::string oversized(kMaxConfirmationBytes + 1, 'x');
  const auto edges_before = scene.repository->edges();
  const std::vector<igtlink::Message> ignored = {
      igtlink::makeMessage("Confirm", igtlink::StringContent{igtlink::kEncodingUsAscii, oversized}),
      igtlink::makeMessage("CMD", igtlink::StringContent{igtlink::kEncodingUsAscii, "Confirm"}),
      igtlink::makeMessage("Confirm", igtlink::TransformContent::fromIsometry(Eigen::Isometry3d::Identity())),
  };
  for (const auto& m : ignored) ASSERT_TRUE(recorder.client().send(m, igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return streamer.stats().client_messages_ignored == ignored.size(); }));
  EXPECT_EQ(confirmations.load(), 0) << "an oversized text, another device, another type: not a confirmation";
  ASSERT_TRUE(recorder.client().send(
      igtlink::makeMessage("Confirm", igtlink::StringContent{igtlink::kEncodingUsAscii, "aligned"}),
      igtlink::HeaderVersion::kV1));
  ASSERT_TRUE(waitFor([&] { return confirmations.load() == 1; }));
  {
    std::lock_guard lock(last_mutex);
    EXPECT_EQ(last, "aligned");
  }
  EXPECT_EQ(streamer.stats().confirmations, 1U);
  streamer.setPrompt("hold it still");
  ASSERT_TRUE(waitFor([&] { return recorder.count("STRING") == 2; }));
  server.stop();
  // Nothing a client sent changed the repository.
  const auto edges_after = scene.repository->edges();
  ASSERT_EQ(edges_after.size(), edges_before.size());
  for (std::size_t i = 0; i < edges_before.size(); ++i) {
    EXPECT_TRUE(edges_after[i].to_T_from.matrix() == edges_before[i].to_T_from.matrix());
  }
  std::vector<std::string> prompts;
  for (const auto& r : recorder.messages()) {
    if (const auto* text = r.message.as<igtlink::StringContent>()) prompts.push_back(text->text);
  }
  EXPECT_EQ(prompts, (std::vector<std::string>{"line up the cube", "hold it still"}));
}

igtlink::Message cameraImageMessage(int width, int height, std::uint8_t components = 1,
                                   igtlink::ScalarType type = igtlink::ScalarType::kUint8,
                                   const std::string& device = kCameraImageDevice) {
  igtlink::ImageContent image;
  image.components = components;
  image.scalar_type = type;
  image.resizeWhole({static_cast<std::uint16_t>(width), static_cast<std::uint16_t>(height), 1});
  for (std::size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] = static_cast<std::uint8_t>(i % 251);
  auto m = igtlink::makeMessage(device, std::move(image), 1.7e9);
  m.metadata.push_back({"CameraIntrinsics", igtlink::kEncodingUsAscii, "1000 1000 32 24 0 0 0 0 0 64 48"});
  return m;
}

TEST(HologramStream, OnlyAWholeGreyPhotoOnHmdCameraReachesItsCallbackWithItsIntrinsics) {
  Scene scene;
  igtlink::ServerOptions server_options = loopback();
  // What the camera step allows: a 4096 x 4096 photo; the bigger image below is refused by the framer.
  server_options.decode.max_body_size = 200 * 1024;
  igtlink::Server server(server_options);
  std::mutex mutex;
  std::vector<HeadsetCameraImage> received;
  auto options = streamOptions(igtlink::HeaderVersion::kV2);
  options.on_camera_image = [&](igtlink::ClientId, HeadsetCameraImage image) {
    std::lock_guard lock(mutex);
    received.push_back(std::move(image));
  };
  HologramStreamer streamer(server, scene.repository, {models()[0]}, options);
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1 && recorder.client().connected(); }));
  const auto edges_before = scene.repository->edges();
  // Not a photo: three components, 16-bit, another device, too small, a stack of slices.
  igtlink::ImageContent stack;
  stack.resizeWhole({64, 48, 2});
  const std::vector<igtlink::Message> ignored = {
      cameraImageMessage(64, 48, 3),
      cameraImageMessage(64, 48, 1, igtlink::ScalarType::kUint16),
      cameraImageMessage(64, 48, 1, igtlink::ScalarType::kUint8, "Probe"),
      cameraImageMessage(8, 8),
      igtlink::makeMessage(kCameraImageDevice, stack),
  };
  for (const auto& m : ignored) ASSERT_TRUE(recorder.client().send(m, igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return streamer.stats().client_messages_ignored == ignored.size(); }));
  ASSERT_TRUE(recorder.client().send(cameraImageMessage(64, 48), igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return streamer.stats().camera_images == 1; }));
  {
    std::lock_guard lock(mutex);
    ASSERT_EQ(received.size(), 1U);
    EXPECT_EQ(received[0].width, 64);
    EXPECT_EQ(received[0].height, 48);
    ASSERT_EQ(received[0].pixels.size(), 64U * 48U);
    EXPECT_EQ(received[0].pixels[300], 300 % 251);
    EXPECT_EQ(received[0].intrinsics, "1000 1000 32 24 0 0 0 0 0 64 48");
    EXPECT_NEAR(received[0].sent_utc, 1.7e9, 1e-3);
  }
  // A photo over the server's body limit closes that client (the framer refuses it), nothing reaches the step.
  ASSERT_TRUE(recorder.client().send(cameraImageMessage(1024, 1024), igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return server.stats().clients_closed_for_protocol_errors == 1; }));
  EXPECT_EQ(streamer.stats().camera_images, 1U);
  server.stop();
  const auto edges_after = scene.repository->edges();
  ASSERT_EQ(edges_after.size(), edges_before.size());
}

TEST(HologramStream, APhotoIsIgnoredUnlessItsOwnerAskedForPhotos) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, {models()[0]}, streamOptions(igtlink::HeaderVersion::kV2));
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1 && recorder.client().connected(); }));
  ASSERT_TRUE(recorder.client().send(cameraImageMessage(64, 48), igtlink::HeaderVersion::kV2));
  ASSERT_TRUE(waitFor([&] { return streamer.stats().client_messages_ignored == 1; }));
  EXPECT_EQ(streamer.stats().camera_images, 0U);
  server.stop();
}

TEST(HologramStream, UnityConventionMovesConvertedMeshesLikeTheOriginal) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, {models()[0]}, streamOptions(igtlink::HeaderVersion::kV2, true));
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  streamer.update(0.0);
  ASSERT_TRUE(waitFor([&] { return recorder.size() == 2; }));
  server.stop();
  const auto received = recorder.messages();
  EXPECT_EQ(received[0].message.metadataValue("Units"), "m");
  const TriangleMesh mesh_unity = igtlink::meshFromPolyData(*received[0].message.as<igtlink::PolyDataContent>());
  const Eigen::Matrix4d t_unity = received[1].message.as<igtlink::TransformContent>()->matrix;
  const TriangleMesh mesh = test::tetrahedron();
  const Eigen::Isometry3d hol_T_vir = scene.hol_T_vir();
  // Every vertex placed in Unity equals the vertex placed in MR-SNS, converted:
  // T_u * v_u == 0.001 * F * (T * v). float32 on the wire: ~1e-7 relative of
  // coordinates up to ~1 m, so 1e-6 m.
  for (Eigen::Index i = 0; i < mesh.vertexCount(); ++i) {
    const Eigen::Vector3d placed_mm = hol_T_vir * Eigen::Vector3d(mesh.vertices.row(i).transpose());
    const Eigen::Vector3d expected_m(-0.001 * placed_mm.x(), 0.001 * placed_mm.y(), 0.001 * placed_mm.z());
    const Eigen::Vector3d placed_m = (t_unity * mesh_unity.vertices.row(i).transpose().homogeneous()).head<3>();
    EXPECT_LT((placed_m - expected_m).norm(), 1e-6) << "vertex " << i;
  }
  // Winding: Unity's front faces are clockwise in its left-handed frame, and
  // its normals (Mesh.RecalculateNormals) are Cross(b - a, c - a), pointing to
  // the front. For the mirrored mesh that vector must be the mirrored outward
  // normal F n: with the original winding it would be -F n (mirroring flips
  // cross products) and Unity would cull the outside of every model.
  auto faceNormal = [](const TriangleMesh& m, Eigen::Index face) {
    const Eigen::Vector3d a = m.vertices.row(m.faces(face, 0)), b = m.vertices.row(m.faces(face, 1)),
                          c = m.vertices.row(m.faces(face, 2));
    return Eigen::Vector3d((b - a).cross(c - a).normalized());
  };
  const Eigen::Vector3d centroid = mesh.vertices.colwise().mean();
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d n = faceNormal(mesh, f);
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0));
    ASSERT_GT(n.dot(a - centroid), 0.0) << "fixture face " << f << " is not outward";
    EXPECT_LT((faceNormal(mesh_unity, f) - Eigen::Vector3d(-n.x(), n.y(), n.z())).norm(), 1e-6) << "face " << f;
  }
}

TEST(UnityConvention, RoundTripsAndPreservesChainsAndRotations) {
  for (int seed = 0; seed < 20; ++seed) {
    Eigen::Isometry3d a = randomPose(seed), b = randomPose(seed + 100);
    if (seed == 0) a = Eigen::Isometry3d::Identity();
    if (seed == 1) a.linear() = so3Exp(Eigen::Vector3d(1e-9, 0, 0));              // tiny
    if (seed == 2) a.linear() = so3Exp(Eigen::Vector3d(0, 0, 3.14159265358979));  // near pi
    const Eigen::Matrix4d ua = transformToUnity(a.matrix());
    EXPECT_TRUE(transformFromUnity(ua).isApprox(a.matrix(), 1e-12)) << seed;
    const Eigen::Matrix3d ru = ua.block(0, 0, 3, 3);
    EXPECT_NEAR(ru.determinant(), 1.0, 1e-12);
    EXPECT_TRUE(isRigid(ua, 1e-9));
    EXPECT_TRUE(transformToUnity((a * b).matrix()).isApprox(ua * transformToUnity(b.matrix()), 1e-12)) << seed;
    EXPECT_NEAR(rotationAngle(ru), rotationAngle(a.linear()), 1e-9);
  }
  TriangleMesh mesh = test::tetrahedron(3.0);
  mesh.normals = mesh.vertices.rowwise().normalized();
  const TriangleMesh back = meshFromUnity(meshToUnity(mesh));
  EXPECT_TRUE(back.vertices.isApprox(mesh.vertices, 1e-12));
  EXPECT_EQ(back.faces, mesh.faces);
  EXPECT_TRUE(back.normals.isApprox(mesh.normals, 1e-12));
  EXPECT_DOUBLE_EQ(meshToUnity(mesh).vertices(1, 0), -0.013);
}

// A deforming model (the live soft tissue): its vertices move on the headsets as NDARRAY (N x 3 float32, the
// model's frame, mm; metres and mirrored x for Unity) after the mesh; a headset that connects later gets the
// mesh, then the latest vertices; a transforms-only client gets none; bad updates are refused.
TEST(HologramStream, VertexUpdatesMoveADeformingModelOnEveryHeadset) {
  Scene scene;
  igtlink::Server server(loopback());
  HologramStreamer streamer(server, scene.repository, models());
  server.start();
  test::Recorder early(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  TriangleMesh moved = test::tetrahedron(20.0);
  moved.vertices.col(0).array() += 1.25;
  streamer.updateMeshVertices("C6", moved.vertices);
  moved.vertices.col(1).array() -= 2.5;
  streamer.updateMeshVertices("C6", moved.vertices);
  ASSERT_TRUE(waitFor([&] { return early.count("NDARRAY") == 2; }));
  test::Recorder late(server.port());
  ASSERT_TRUE(waitFor([&] { return late.count("NDARRAY") == 1; }));
  EXPECT_THROW(streamer.updateMeshVertices("C7", moved.vertices), InvalidArgumentError);
  EXPECT_THROW(streamer.updateMeshVertices("C6", moved.vertices.topRows(2)), InvalidArgumentError);
  TriangleMesh bad = moved;
  bad.vertices(0, 0) = NAN;
  EXPECT_THROW(streamer.updateMeshVertices("C6", bad.vertices), InvalidArgumentError);
  server.stop();
  for (const auto* r : {&early, &late}) {
    const auto received = r->messages();
    ASSERT_GE(received.size(), 3U);
    ASSERT_EQ(received[1].message.header.type, "POLYDATA") << "the mesh comes first";
    const auto& last = received.back().message;
    ASSERT_EQ(last.header.type, "NDARRAY");
    EXPECT_EQ(last.header.device_name, "C6");
    EXPECT_EQ(last.metadataValue("Units"), "mm");
    const auto array = igtlink::decodeNdArray(last.as<igtlink::RawContent>()->bytes);
    ASSERT_EQ(array.size, (std::vector<std::uint16_t>{static_cast<std::uint16_t>(moved.vertices.rows()), 3}));
    for (Eigen::Index i = 0; i < moved.vertices.rows(); ++i) {
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(array.values[static_cast<std::size_t>(3 * i + c)], static_cast<float>(moved.vertices(i, c)));
      }
    }
  }
  EXPECT_EQ(streamer.stats().vertex_updates_queued, 3U);

  // Unity: metres, x mirrored, as the meshes.
  igtlink::Server unity_server(loopback());
  HologramStreamer unity(unity_server, scene.repository, models(), streamOptions(igtlink::HeaderVersion::kV2, true));
  unity_server.start();
  test::Recorder headset(unity_server.port());
  ASSERT_TRUE(waitFor([&] { return unity.readyClients() == 1; }));
  unity.updateMeshVertices("C6", moved.vertices);
  ASSERT_TRUE(waitFor([&] { return headset.count("NDARRAY") == 1; }));
  unity_server.stop();
  const auto u = igtlink::decodeNdArray(headset.messages().back().message.as<igtlink::RawContent>()->bytes);
  const TriangleMesh expected = meshToUnity(moved);
  for (Eigen::Index i = 0; i < moved.vertices.rows(); ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(u.values[static_cast<std::size_t>(3 * i + c)], expected.vertices(i, c), 1e-7);
    }
  }

  // A transforms-only client (its models are its own) gets no vertex update.
  igtlink::Server plain_server(loopback());
  HologramStreamOptions plain;
  plain.transforms_only = true;
  HologramStreamer transforms_only(plain_server, scene.repository, models(), plain);
  plain_server.start();
  test::Recorder plain_client(plain_server.port());
  ASSERT_TRUE(waitFor([&] { return transforms_only.readyClients() == 1; }));
  transforms_only.updateMeshVertices("C6", moved.vertices);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  plain_server.stop();
  EXPECT_EQ(plain_client.count("NDARRAY"), 0U);
}

TEST(HologramStream, RefusesBadModels) {
  Scene scene;
  igtlink::Server server(loopback());
  EXPECT_THROW(HologramStreamer(server, scene.repository, {{"", test::tetrahedron(), "V"}}), InvalidArgumentError);
  EXPECT_THROW(HologramStreamer(server, scene.repository, {{"ANameLongerThanTwentyChars", test::tetrahedron(), "V"}}),
               InvalidArgumentError);
  EXPECT_THROW(
      HologramStreamer(server, scene.repository, {{"A", test::tetrahedron(), "V"}, {"A", test::tetrahedron(), "V"}}),
      InvalidArgumentError);
  EXPECT_THROW(HologramStreamer(server, scene.repository, {{"A", TriangleMesh{}, "V"}}), InvalidArgumentError);
  EXPECT_THROW(HologramStreamer(server, nullptr, models()), InvalidArgumentError);
}

// The recording played through the streamer (forwarded tool transforms) to a
// client: every transform of every frame arrives, as float32, with its frame's timestamp.
TEST(HologramStream, PlaybackThroughTheStreamReproducesEveryTransformOfTheFile) {
  MRSNS_REQUIRE_DATA(file, "plus/fCal_Test_Calibration_3NWires.igs.mha");
  const TrackedSequence sequence = io::readSequenceHeader(file);
  auto repository = std::make_shared<TransformRepository>();
  PlaybackOptions playback_options;
  playback_options.speed = 20.0;  // 0.75 s; about 250 messages/s, far from the stream queue's limit
  PlaybackTrackingSource source(repository, file, playback_options);
  auto server_options = loopback();
  server_options.stream_queue_limit = 4096;  // this test is about content, not the drop policy of a stalled client
  igtlink::Server server(server_options);
  HologramStreamer streamer(server, repository, {},
                            streamOptions(igtlink::HeaderVersion::kV1, false, sequence.transformNames()));
  source.setUpdateCallback([&](std::span<const ToolUpdate> u) { streamer.update(u.front().timestamp); });
  server.start();
  test::Recorder recorder(server.port());
  ASSERT_TRUE(waitFor([&] { return streamer.readyClients() == 1; }));
  source.start();
  ASSERT_TRUE(waitFor([&] { return source.status().state == SourceState::Finished; }, 10.0));
  const std::size_t expected = 3 * sequence.frames.size();
  ASSERT_TRUE(waitFor([&] { return recorder.count("TRANSFORM") >= expected; }, 5.0))
      << recorder.count("TRANSFORM") << " of " << expected;
  server.stop();
  EXPECT_EQ(server.stats().stream_messages_dropped, 0U);
  std::map<std::pair<std::string, std::uint64_t>, Eigen::Matrix4d> by_key;
  for (const auto& r : recorder.messages()) {
    by_key[{r.message.header.device_name, r.message.header.timestamp}] =
        r.message.as<igtlink::TransformContent>()->matrix;
  }
  std::size_t matched = 0;
  double max_error = 0.0;
  for (const auto& frame : sequence.frames) {
    for (const auto& [name, transform] : frame.transforms) {
      const auto it = by_key.find({name, igtlink::timestampFromSeconds(frame.timestamp)});
      ASSERT_NE(it, by_key.end()) << name << " at " << frame.timestamp;
      // What went on the wire is the repository's rigid transform (file
      // rounding repaired, see Playback tests), then float32.
      TransformRepository scratch;
      Eigen::Matrix4d sent;
      try {
        scratch.setTransform(name, Eigen::Isometry3d(transform.matrix));
        sent = transform.matrix;
      } catch (const InvalidArgumentError&) {
        sent = orthonormalize(transform.matrix).matrix();
      }
      EXPECT_TRUE(test::equalAsFloat32(it->second, sent)) << name << " at " << frame.timestamp;
      max_error = std::max(max_error, (it->second - transform.matrix).cwiseAbs().maxCoeff());
      ++matched;
    }
  }
  EXPECT_EQ(matched, expected);
  // Against the file as printed: float32 of ~300 mm is 2e-5 mm, rounding of the rotations ~1e-6.
  EXPECT_LT(max_error, 1e-4);
  RecordProperty("max_abs_error_vs_file", std::to_string(max_error));
}

}  // namespace
}  // namespace mrsns::tracking
