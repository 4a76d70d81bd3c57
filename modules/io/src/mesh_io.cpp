// All VTK code of the mesh formats lives in this one translation unit (VTK
// headers are slow to compile and must stay out of public headers).
#include "mrsns/io/mesh_io.h"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkLogger.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkOBJWriter.h>
#include <vtkObjectFactory.h>
#include <vtkOutputWindow.h>
#include <vtkPLYReader.h>
#include <vtkPLYWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataReader.h>
#include <vtkPolyDataWriter.h>
#include <vtkSTLReader.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkTriangleFilter.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>
#include <vector>

#include "io_text.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/file_names.h"

namespace mrsns::io {
namespace {

using detail::quoted;

/// Messages VTK reports while a VtkMessageCapture is alive on this thread.
thread_local std::vector<std::string>* t_vtk_messages = nullptr;

/// Routes VTK's error and warning output to our logger instead of stderr,
/// and hands errors to the reader that is running so it can refuse the file
/// (VTK readers report malformed input this way and still "succeed").
class MrsnsVtkOutputWindow : public vtkOutputWindow {
 public:
  static MrsnsVtkOutputWindow* New();
  vtkTypeMacro(MrsnsVtkOutputWindow, vtkOutputWindow)

      void DisplayText(const char* text) override {
    const std::string message = text != nullptr ? text : "";
    const auto type = GetCurrentMessageType();
    if ((type == MESSAGE_TYPE_ERROR || type == MESSAGE_TYPE_WARNING) && t_vtk_messages != nullptr) {
      t_vtk_messages->push_back(message);
    }
    if (type == MESSAGE_TYPE_ERROR) {
      logger()->debug("VTK error: {}", message);
    } else {
      logger()->debug("VTK: {}", message);
    }
  }
};
vtkStandardNewMacro(MrsnsVtkOutputWindow);

void installVtkOutputWindow() {
  static std::once_flag once;
  std::call_once(once, [] {
    vtkNew<MrsnsVtkOutputWindow> window;
    vtkOutputWindow::SetInstance(window);
    // VTK also logs errors through vtkLogger straight to stderr; they reach
    // our logger through the output window above.
    vtkLogger::SetStderrVerbosity(vtkLogger::VERBOSITY_OFF);
  });
}

class VtkMessageCapture {
 public:
  VtkMessageCapture() {
    installVtkOutputWindow();
    previous_ = t_vtk_messages;
    t_vtk_messages = &messages_;
  }
  ~VtkMessageCapture() { t_vtk_messages = previous_; }
  VtkMessageCapture(const VtkMessageCapture&) = delete;
  VtkMessageCapture& operator=(const VtkMessageCapture&) = delete;

  /// The first error-like line, trimmed, or empty.
  [[nodiscard]] std::string firstError() const {
    for (const auto& m : messages_) {
      if (m.find("rror") == std::string::npos) continue;
      std::string line = m;
      // VTK prefixes "ERROR: In file, line N\nclassName (0x...): message".
      const auto nl = line.find('\n');
      if (nl != std::string::npos) line = line.substr(nl + 1);
      const auto colon = line.find("): ");
      if (colon != std::string::npos) line = line.substr(colon + 3);
      while (!line.empty() && std::isspace(static_cast<unsigned char>(line.back()))) line.pop_back();
      return line;
    }
    return {};
  }

 private:
  std::vector<std::string> messages_;
  std::vector<std::string>* previous_ = nullptr;
};


/// A binary STL is exactly 84 + 50 n bytes; anything else must be ASCII
/// ("solid ..."). Checked before VTK sees the file, because VTK reads garbage
/// as a binary STL of random triangles.
void checkStlLayout(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError("cannot open mesh file " + quoted(path) + ": check that it exists and is readable");
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  char header[84] = {};
  in.read(header, sizeof header);
  const auto got = static_cast<std::size_t>(in.gcount());
  std::string start(header, std::min<std::size_t>(got, 80));
  const auto first = start.find_first_not_of(" \t\r\n");
  const bool ascii_start = first != std::string::npos && start.compare(first, 5, "solid") == 0;
  if (got == 84) {
    std::uint32_t count = 0;
    std::memcpy(&count, header + 80, 4);
    if (count > 0 && size == 84 + 50ULL * count) return;  // a consistent binary STL
    if (!ascii_start) {
      throw FormatError("mesh file " + quoted(path) + " is not a valid STL: as binary STL its header declares " +
                        std::to_string(count) + " triangles (" + std::to_string(84 + 50ULL * count) +
                        " bytes) but the file has " + std::to_string(size) +
                        " bytes, and it does not start with 'solid' as an ASCII STL does");
    }
    return;
  }
  if (!ascii_start) {
    throw FormatError("mesh file " + quoted(path) + " is not a valid STL: it is only " + std::to_string(size) +
                      " bytes and does not start with 'solid'");
  }
}

vtkSmartPointer<vtkPolyData> readPolyData(const std::filesystem::path& path, MeshFormat format) {
  const std::string file = path.string();
  vtkSmartPointer<vtkPolyData> output;
  auto run = [&](auto reader) {
    reader->SetFileName(file.c_str());
    reader->Update();
    output = reader->GetOutput();
    return reader->GetErrorCode();
  };
  unsigned long error_code = 0;
  switch (format) {
    case MeshFormat::Stl: {
      checkStlLayout(path);
      auto reader = vtkSmartPointer<vtkSTLReader>::New();
      reader->MergingOn();  // STL repeats each vertex per triangle; merge to get a connected mesh
      error_code = run(reader);
      break;
    }
    case MeshFormat::Vtp: {
      auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
      if (reader->CanReadFile(file.c_str()) == 0) {
        throw FormatError("mesh file " + quoted(path) + " is not a VTK XML PolyData file (.vtp)");
      }
      error_code = run(reader);
      break;
    }
    case MeshFormat::VtkLegacy: {
      auto reader = vtkSmartPointer<vtkPolyDataReader>::New();
      error_code = run(reader);
      break;
    }
    case MeshFormat::Obj: error_code = run(vtkSmartPointer<vtkOBJReader>::New()); break;
    case MeshFormat::Ply: {
      auto reader = vtkSmartPointer<vtkPLYReader>::New();
      if (reader->CanReadFile(file.c_str()) == 0) {
        throw FormatError("mesh file " + quoted(path) + " is not a PLY file (no 'ply' header)");
      }
      error_code = run(reader);
      break;
    }
  }
  if (error_code != 0 && output == nullptr) {
    throw FormatError("mesh file " + quoted(path) + " could not be read (VTK error code " + std::to_string(error_code) +
                      ")");
  }
  return output;
}

Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> tupleMatrix(vtkDataArray* array) {
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> m(array->GetNumberOfTuples(), 3);
  for (vtkIdType i = 0; i < array->GetNumberOfTuples(); ++i) {
    for (int c = 0; c < 3; ++c) m(i, c) = array->GetComponent(i, c);
  }
  return m;
}

/// Per-vertex RGB(A) colours: unsigned char 0..255 or floating point 0..1.
vtkDataArray* findColors(vtkPointData* pd) {
  vtkDataArray* candidates[] = {pd->GetScalars(), pd->GetArray("RGB"), pd->GetArray("RGBA"), pd->GetArray("Colors")};
  for (vtkDataArray* a : candidates) {
    if (a != nullptr && (a->GetNumberOfComponents() == 3 || a->GetNumberOfComponents() == 4)) return a;
  }
  return nullptr;
}

TriangleMesh toTriangleMesh(vtkPolyData* input, const std::filesystem::path& path) {
  const vtkIdType n_points = input->GetNumberOfPoints();
  if (n_points == 0 || input->GetNumberOfCells() == 0) {
    throw FormatError("mesh file " + quoted(path) + " holds no " + (n_points == 0 ? "points" : "cells") +
                      ": it is empty or not a mesh");
  }
  vtkSmartPointer<vtkPolyData> poly = input;
  if (input->GetNumberOfPolys() + input->GetNumberOfStrips() > 0) {
    vtkNew<vtkTriangleFilter> triangulate;
    triangulate->SetInputData(input);
    triangulate->PassVertsOff();
    triangulate->PassLinesOff();
    triangulate->Update();
    poly = triangulate->GetOutput();
  }
  TriangleMesh mesh;
  mesh.name = path.stem().string();
  mesh.vertices.resize(poly->GetNumberOfPoints(), 3);
  for (vtkIdType i = 0; i < poly->GetNumberOfPoints(); ++i) {
    double p[3];
    poly->GetPoint(i, p);
    mesh.vertices.row(i) << p[0], p[1], p[2];
  }
  if (!mesh.vertices.allFinite()) {
    throw FormatError("mesh file " + quoted(path) + " has non-finite (NaN or infinite) vertex coordinates");
  }
  vtkCellArray* polys = poly->GetPolys();
  std::vector<std::int32_t> indices;
  if (polys != nullptr && input->GetNumberOfPolys() + input->GetNumberOfStrips() > 0) {
    indices.reserve(static_cast<std::size_t>(polys->GetNumberOfCells()) * 3);
    vtkNew<vtkIdList> ids;
    for (polys->InitTraversal(); polys->GetNextCell(ids) != 0;) {
      if (ids->GetNumberOfIds() != 3) continue;  // degenerate polygons the triangulation dropped to fewer points
      for (vtkIdType k = 0; k < 3; ++k) {
        const vtkIdType id = ids->GetId(k);
        if (id < 0 || id >= mesh.vertices.rows()) {
          throw FormatError("mesh file " + quoted(path) + " has a face index out of range (" + std::to_string(id) +
                            " for " + std::to_string(mesh.vertices.rows()) + " points)");
        }
        indices.push_back(static_cast<std::int32_t>(id));
      }
    }
  }
  mesh.faces.resize(static_cast<Eigen::Index>(indices.size() / 3), 3);
  std::copy(indices.begin(), indices.end(), mesh.faces.data());

  vtkPointData* pd = poly->GetPointData();
  if (vtkDataArray* normals = pd->GetNormals(); normals != nullptr && normals->GetNumberOfComponents() == 3 &&
                                                normals->GetNumberOfTuples() == n_points &&
                                                poly->GetNumberOfPoints() == n_points) {
    mesh.normals = tupleMatrix(normals);
    if (!mesh.normals.allFinite()) mesh.normals.resize(0, 3);
  }
  if (vtkDataArray* colors = findColors(pd);
      colors != nullptr && colors->GetNumberOfTuples() == poly->GetNumberOfPoints()) {
    mesh.colors = tupleMatrix(colors);
    if (colors->GetDataType() == VTK_UNSIGNED_CHAR || mesh.colors.maxCoeff() > 1.0) mesh.colors /= 255.0;
    if (!mesh.colors.allFinite()) mesh.colors.resize(0, 3);
  }
  return mesh;
}

vtkSmartPointer<vtkPolyData> toPolyData(const TriangleMesh& mesh, const std::filesystem::path& path) {
  if (mesh.vertices.rows() == 0) {
    throw InvalidArgumentError("cannot write mesh to " + quoted(path) + ": it has no vertices");
  }
  if (!mesh.vertices.allFinite()) {
    throw InvalidArgumentError("cannot write mesh to " + quoted(path) + ": it has non-finite vertices");
  }
  if (mesh.faces.rows() > 0 && (mesh.faces.minCoeff() < 0 || mesh.faces.maxCoeff() >= mesh.vertices.rows())) {
    throw InvalidArgumentError("cannot write mesh to " + quoted(path) + ": a face index is out of range");
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(mesh.vertices.rows());
  for (Eigen::Index i = 0; i < mesh.vertices.rows(); ++i) {
    points->SetPoint(i, mesh.vertices(i, 0), mesh.vertices(i, 1), mesh.vertices(i, 2));
  }
  poly->SetPoints(points);
  vtkNew<vtkCellArray> cells;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const vtkIdType ids[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    cells->InsertNextCell(3, ids);
  }
  poly->SetPolys(cells);
  if (mesh.normals.rows() == mesh.vertices.rows()) {
    vtkNew<vtkDoubleArray> normals;
    normals->SetName("Normals");
    normals->SetNumberOfComponents(3);
    normals->SetNumberOfTuples(mesh.normals.rows());
    for (Eigen::Index i = 0; i < mesh.normals.rows(); ++i) {
      normals->SetTuple3(i, mesh.normals(i, 0), mesh.normals(i, 1), mesh.normals(i, 2));
    }
    poly->GetPointData()->SetNormals(normals);
  }
  if (mesh.colors.rows() == mesh.vertices.rows()) {
    vtkNew<vtkUnsignedCharArray> colors;
    colors->SetName("RGB");
    colors->SetNumberOfComponents(3);
    colors->SetNumberOfTuples(mesh.colors.rows());
    for (Eigen::Index i = 0; i < mesh.colors.rows(); ++i) {
      for (int c = 0; c < 3; ++c) {
        colors->SetValue(i * 3 + c,
                         static_cast<unsigned char>(std::lround(std::clamp(mesh.colors(i, c), 0.0, 1.0) * 255.0)));
      }
    }
    poly->GetPointData()->SetScalars(colors);
  }
  return poly;
}

}  // namespace

MeshFormat meshFormatFromPath(const std::filesystem::path& path) {
  const std::string ext = lowerExtension(path);
  if (ext == ".stl") return MeshFormat::Stl;
  if (ext == ".vtp") return MeshFormat::Vtp;
  if (ext == ".vtk") return MeshFormat::VtkLegacy;
  if (ext == ".obj") return MeshFormat::Obj;
  if (ext == ".ply") return MeshFormat::Ply;
  throw UnsupportedError("mesh file " + quoted(path) + " has an unknown extension '" + ext +
                         "': use .stl, .vtp, .vtk, .obj or .ply");
}

std::string meshFormatName(MeshFormat format) {
  switch (format) {
    case MeshFormat::Stl: return "stl";
    case MeshFormat::Vtp: return "vtp";
    case MeshFormat::VtkLegacy: return "vtk";
    case MeshFormat::Obj: return "obj";
    case MeshFormat::Ply: return "ply";
  }
  return "unknown";
}

TriangleMesh readMesh(const std::filesystem::path& path) {
  const MeshFormat format = meshFormatFromPath(path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw FileError("mesh file " + quoted(path) + " does not exist or is not a regular file");
  }
  {
    std::ifstream probe(path, std::ios::binary);
    if (!probe) throw FileError("cannot open mesh file " + quoted(path) + ": check its permissions");
  }
  VtkMessageCapture capture;
  vtkSmartPointer<vtkPolyData> poly = readPolyData(path, format);
  if (const std::string error = capture.firstError(); !error.empty()) {
    throw FormatError("mesh file " + quoted(path) + " is malformed: " + error);
  }
  if (poly == nullptr) throw FormatError("mesh file " + quoted(path) + " could not be read");
  return toTriangleMesh(poly, path);
}

void writeMesh(const TriangleMesh& mesh, const std::filesystem::path& path, const MeshWriteOptions& options) {
  const MeshFormat format = meshFormatFromPath(path);
  VtkMessageCapture capture;
  vtkSmartPointer<vtkPolyData> poly = toPolyData(mesh, path);
  const std::string file = path.string();
  int ok = 0;
  switch (format) {
    case MeshFormat::Stl: {
      if (mesh.faces.rows() == 0) {
        throw InvalidArgumentError("cannot write " + quoted(path) + ": STL holds triangles only and the mesh has none");
      }
      vtkNew<vtkSTLWriter> writer;
      writer->SetInputData(poly);
      writer->SetFileName(file.c_str());
      if (options.binary)
        writer->SetFileTypeToBinary();
      else
        writer->SetFileTypeToASCII();
      ok = writer->Write();
      break;
    }
    case MeshFormat::Vtp: {
      vtkNew<vtkXMLPolyDataWriter> writer;
      writer->SetInputData(poly);
      writer->SetFileName(file.c_str());
      if (options.binary)
        writer->SetDataModeToAppended();
      else
        writer->SetDataModeToAscii();
      if (!options.compress) {
        writer->SetCompressorTypeToNone();
      } else {
        // zlib's fastest level: a tenth larger than its default, in a third of the time (a session's models are
        // written whenever they are made, ten vertebrae and their headset copies at once).
        writer->SetCompressorTypeToZLib();
        writer->SetCompressionLevel(1);
      }
      ok = writer->Write();
      break;
    }
    case MeshFormat::VtkLegacy: {
      vtkNew<vtkPolyDataWriter> writer;
      writer->SetInputData(poly);
      writer->SetFileName(file.c_str());
      if (options.binary)
        writer->SetFileTypeToBinary();
      else
        writer->SetFileTypeToASCII();
      ok = writer->Write();
      break;
    }
    case MeshFormat::Obj: {
      vtkNew<vtkOBJWriter> writer;
      writer->SetInputData(poly);
      writer->SetFileName(file.c_str());
      ok = writer->Write();
      break;
    }
    case MeshFormat::Ply: {
      vtkNew<vtkPLYWriter> writer;
      writer->SetInputData(poly);
      writer->SetFileName(file.c_str());
      if (options.binary)
        writer->SetFileTypeToBinary();
      else
        writer->SetFileTypeToASCII();
      if (mesh.colors.rows() == mesh.vertices.rows()) {
        writer->SetArrayName("RGB");
        writer->SetColorModeToDefault();
      }
      ok = writer->Write();
      break;
    }
  }
  std::error_code ec;
  if (ok != 1 || !capture.firstError().empty() || !std::filesystem::exists(path, ec)) {
    throw FileError("writing mesh file " + quoted(path) + " failed" +
                    (capture.firstError().empty() ? std::string() : ": " + capture.firstError()) +
                    " (check the folder exists and is writable)");
  }
}

}  // namespace mrsns::io
