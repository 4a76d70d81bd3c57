// Debian's libopenigtlink 1.11 (header v1, written by the OpenIGTLink
// project, not here) as the receiving client of the real `mrsns-cli serve`:
// the model arrives first as POLYDATA, then TRANSFORMs, every message with a
// CRC that libopenigtlink checks.
#include <gtest/gtest.h>
#include <igtlClientSocket.h>
#include <igtlMessageHeader.h>
#include <igtlPolyDataMessage.h>
#include <igtlTransformMessage.h>

#include <thread>

#include "../cli/serve_process.h"
#include "mrsns/io/mesh_io.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

TriangleMesh tetrahedron() {
  TriangleMesh mesh;
  mesh.vertices.resize(4, 3);
  mesh.vertices << 0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10;
  mesh.faces.resize(4, 3);
  mesh.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return mesh;
}

TEST(LibOpenIGTLink, ReceivesTheHologramStreamOfServe) {
  const auto dir = scratchDirectory("interop");
  io::writeMesh(tetrahedron(), dir / "Vertebra.stl");
  const auto port = freePort();
  ServeProcess serve({"--port", std::to_string(port), "--source", "simulator", "--rate", "100", "--igtl-version", "1",
                      "--models", (dir / "Vertebra.stl").string(), "--duration", "20"});
  ASSERT_TRUE(serve.started());

  igtl::ClientSocket::Pointer socket = igtl::ClientSocket::New();
  bool connected = false;
  for (int attempt = 0; attempt < 500 && !connected; ++attempt) {
    connected = socket->ConnectToServer("127.0.0.1", port) == 0;
    if (!connected) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_TRUE(connected) << "serve did not listen on port " << port;
  socket->SetReceiveTimeout(5000);

  std::vector<std::string> types;
  int polydata_points = 0;
  int polydata_polygons = 0;
  int transforms = 0;
  int crc_failures = 0;
  while (transforms < 30) {
    igtl::MessageHeader::Pointer header = igtl::MessageHeader::New();
    header->InitPack();
    if (socket->Receive(header->GetPackPointer(), header->GetPackSize()) != header->GetPackSize()) break;
    header->Unpack();
    const std::string type = header->GetDeviceType();
    types.push_back(type);
    if (type == "POLYDATA") {
      igtl::PolyDataMessage::Pointer polydata = igtl::PolyDataMessage::New();
      polydata->SetMessageHeader(header);
      polydata->AllocatePack();
      socket->Receive(polydata->GetPackBodyPointer(), polydata->GetPackBodySize());
      if (!(polydata->Unpack(1) & igtl::MessageHeader::UNPACK_BODY)) ++crc_failures;
      EXPECT_STREQ(polydata->GetDeviceName(), "Vertebra");
      polydata_points = polydata->GetPoints()->GetNumberOfPoints();
      polydata_polygons = static_cast<int>(polydata->GetPolygons()->GetNumberOfCells());
      float max_z = 0.0F;
      for (int i = 0; i < polydata_points; ++i) {
        igtlFloat32 p[3];
        polydata->GetPoints()->GetPoint(i, p);
        max_z = std::max(max_z, p[2]);
      }
      EXPECT_FLOAT_EQ(max_z, 10.0F);  // millimetres, no Unity conversion asked
    } else if (type == "TRANSFORM") {
      igtl::TransformMessage::Pointer transform = igtl::TransformMessage::New();
      transform->SetMessageHeader(header);
      transform->AllocatePack();
      socket->Receive(transform->GetPackBodyPointer(), transform->GetPackBodySize());
      if (!(transform->Unpack(1) & igtl::MessageHeader::UNPACK_BODY)) ++crc_failures;
      EXPECT_STREQ(transform->GetDeviceName(), "Vertebra");
      igtl::Matrix4x4 m;
      transform->GetMatrix(m);
      // The simulated patient reference: 1 m in front of the tracker, with
      // 0.5 mm tremor, 1 mm drift and 0.25 mm noise.
      EXPECT_NEAR(m[2][3], -1000.0, 5.0);
      EXPECT_NEAR(m[0][0] * m[0][0] + m[1][0] * m[1][0] + m[2][0] * m[2][0], 1.0, 1e-5);
      ++transforms;
    } else {
      std::vector<char> skip(header->GetBodySizeToRead());
      socket->Receive(skip.data(), static_cast<int>(skip.size()));
    }
  }
  socket->CloseSocket();
  serve.terminate();
  const auto result = serve.wait();
  EXPECT_EQ(result.exit_code, 0) << result.err;
  ASSERT_FALSE(types.empty());
  EXPECT_EQ(types.front(), "POLYDATA");
  EXPECT_EQ(transforms, 30);
  EXPECT_EQ(crc_failures, 0);
  EXPECT_EQ(polydata_points, 4);
  EXPECT_EQ(polydata_polygons, 4);
}

}  // namespace
}  // namespace mrsns::test
