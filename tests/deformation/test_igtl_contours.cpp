// External segmenter contours over OpenIGTLink: POLYDATA and POINT messages
// through the in-project server and client on 127.0.0.1, into a ContourInbox,
// into the tracker.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <numbers>
#include <thread>

#include "mrsns/core/mesh_ops.h"
#include "mrsns/deformation/igtl_contours.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/vessel_phantom.h"
#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::deformation {
namespace {

Polyline3d circle(const Eigen::Vector2d& c, double r, int n) {
  Polyline3d p;
  p.closed = true;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    p.points.emplace_back(c.x() + r * std::cos(a), c.y() + r * std::sin(a), 0.0);
  }
  return p;
}

bool waitFor(const std::function<bool()>& done, double seconds = 5.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return done();
}

TEST(IgtlContours, PolyDataAndPointMessagesRoundTripWithoutTheNetwork) {
  const std::vector<Polyline3d> in{circle({10, 8}, 3.0, 24), circle({20, 9}, 2.0, 16)};
  for (const auto& msg :
       {contoursToPolyDataMessage(in, "VesselContours", 12.5), contoursToPointMessage(in, "VesselContours", 12.5)}) {
    const ContourMessageResult r = contoursFromMessage(msg);
    ASSERT_TRUE(r.ok) << r.status;
    EXPECT_EQ(r.contours.device, "VesselContours");
    EXPECT_NEAR(r.contours.timestamp_s, 12.5, 1e-6);
    ASSERT_EQ(r.contours.contours.size(), 2u);
    for (std::size_t c = 0; c < 2; ++c) {
      ASSERT_EQ(r.contours.contours[c].points.size(), in[c].points.size());
      EXPECT_TRUE(r.contours.contours[c].closed);
      for (std::size_t k = 0; k < in[c].points.size(); ++k) {
        EXPECT_LT((r.contours.contours[c].points[k] - in[c].points[k]).norm(), 1e-5);  // float32 on the wire
      }
    }
  }
}

TEST(IgtlContours, MessagesWithoutUsableContoursAreReportedNotThrown) {
  const std::vector<Polyline3d> tiny{circle({1, 1}, 1.0, 3)};
  EXPECT_FALSE(contoursFromMessage(contoursToPolyDataMessage(tiny, "C", 0.0)).ok);
  igtlink::StringContent text;
  text.text = "hello";
  const auto r = contoursFromMessage(igtlink::makeMessage("C", text, 0.0));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.status.find("POLYDATA or POINT"), std::string::npos) << r.status;
  std::vector<Polyline3d> nan{circle({1, 1}, 1.0, 8)};
  nan[0].points[2].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(contoursFromMessage(contoursToPointMessage(nan, "C", 0.0)).ok);
  ContourInbox inbox;
  EXPECT_FALSE(inbox.push(igtlink::makeMessage("C", text, 0.0)));
  EXPECT_EQ(inbox.refused(), 1u);
  EXPECT_EQ(inbox.size(), 0u);
}

TEST(IgtlContours, InboxPairsContoursWithTheirFrameByTimestamp) {
  ContourInbox inbox(4);
  for (int i = 0; i < 6; ++i) inbox.push(ExternalContours{1.0 + 0.1 * i, "C", {circle({0, 0}, 1.0 + i, 8)}});
  EXPECT_EQ(inbox.size(), 4u);  // capacity: the two oldest were dropped
  EXPECT_FALSE(inbox.take(1.05, 0.02).has_value());
  const auto e = inbox.take(1.31, 0.02);
  ASSERT_TRUE(e.has_value());
  EXPECT_NEAR(e->timestamp_s, 1.3, 1e-12);
  EXPECT_EQ(inbox.size(), 2u);  // 1.2 (older) went with it
}

// The external segmenter is an OpenIGTLink server (as a Mask R-CNN process
// would be); the navigation side connects with the in-project client.
TEST(IgtlContours, ContoursOverOpenIgtLinkUpdateTheTracker) {
  // A small model: the phantom with random stretches; the observed shape is one more sample.
  std::mt19937_64 rng(5);
  VesselPhantomOptions po;
  po.cca_length_mm = 12.0;
  po.branch_length_mm = 10.0;
  po.ring_vertices = 16;
  std::vector<TriangleMesh> training;
  for (int i = 0; i < 8; ++i) training.push_back(makeVesselPhantom(randomVesselDeformation(rng, 3, 1.5), po));
  ShapeModelBuildOptions b;
  b.align = false;
  const ShapeModel model = buildShapeModel(training, b).model;
  const TriangleMesh truth = makeVesselPhantom(randomVesselDeformation(rng, 3, 1.5), po);
  // A transverse image plane through the CCA: image x lateral, y depth.
  Eigen::Isometry3d model_T_image = Eigen::Isometry3d::Identity();
  model_T_image.translation() = Eigen::Vector3d(-16.0, -12.0, -6.0);
  const TriangleMesh in_image = transformMesh(truth, model_T_image.inverse());
  const auto cut = intersectMeshWithPlane(in_image, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  ASSERT_FALSE(cut.empty());

  igtlink::ServerOptions so;
  so.port = 0;
  igtlink::Server server(so);
  server.start();
  ContourInbox inbox;
  igtlink::ClientOptions co;
  co.port = server.port();
  igtlink::Client client(co);
  client.onMessage([&](const igtlink::Message& m) { (void)inbox.push(m); });
  client.start();
  ASSERT_TRUE(waitFor([&] { return server.stats().clients == 1; }));
  server.broadcast(contoursToPolyDataMessage(cut, "VesselContours", 100.0), igtlink::HeaderVersion::kV2,
                   igtlink::Channel::Reliable);
  server.broadcast(contoursToPointMessage(cut, "VesselContours", 100.05), igtlink::HeaderVersion::kV1,
                   igtlink::Channel::Reliable);
  ASSERT_TRUE(waitFor([&] { return inbox.size() == 2; }));
  client.stop();
  server.stop();

  PosteriorShapeTracker tracker(model);
  const double before = meanVertexDistance(model.mean, shapeVector(truth.vertices));
  for (double t : {100.0, 100.05}) {
    const auto e = inbox.take(t, 0.01);
    ASSERT_TRUE(e.has_value());
    ASSERT_EQ(e->contours.size(), cut.size());
    const FrameUpdate u = tracker.update(model_T_image, e->contours);
    EXPECT_TRUE(u.updated) << u.status;
    EXPECT_GT(u.matched_contours, 0);
  }
  // The contours came from the truth: the observed ring moves towards it.
  const auto& obs = tracker.observations();
  ASSERT_FALSE(obs.empty());
  double prior_res = 0.0, post_res = 0.0;
  for (const auto& o : obs) {
    prior_res += (observationMean(model, o) - o.point).norm();
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4; ++k) {
      if (o.vertices[k] >= 0) p += o.weights[k] * tracker.currentShape().segment<3>(3 * o.vertices[k]);
    }
    post_res += (p - o.point).norm();
  }
  EXPECT_LT(post_res, 0.7 * prior_res) << "prior mean distance to truth " << before << " mm";
}

}  // namespace
}  // namespace mrsns::deformation
