// All ITK calls of the io module's images and transforms: one translation
// unit (each ITK TU costs ~9 s to compile), and no Eigen/core geometry
// headers here (see itk_bridge.h for why).
#include "itk_bridge.h"

#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <itkAffineTransform.h>
#include <itkCompositeTransform.h>
#include <itkGDCMImageIO.h>
#include <itkGDCMImageIOFactory.h>
#include <itkGDCMSeriesFileNames.h>
#include <itkHDF5TransformIOFactory.h>
#include <itkImageIOBase.h>
#include <itkMatlabTransformIOFactory.h>
#include <itkMatrixOffsetTransformBase.h>
#include <itkMetaImageIO.h>
#include <itkMetaImageIOFactory.h>
#include <itkNiftiImageIO.h>
#include <itkNiftiImageIOFactory.h>
#include <itkNrrdImageIO.h>
#include <itkNrrdImageIOFactory.h>
#include <itkTransformFactoryBase.h>
#include <itkTransformFileReader.h>
#include <itkTransformFileWriter.h>
#include <itkTxtTransformIOFactory.h>

#include <algorithm>
#include <cctype>
#include <limits>
#include <mutex>
#include <set>

#include "io_text.h"
#include "mrsns/core/error.h"

namespace mrsns::io::detail {
namespace {


/// ITK's descriptions span several lines; keep one.
std::string itkMessage(const itk::ExceptionObject& e) {
  std::string text = e.GetDescription();
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back()))) text.pop_back();
  std::replace(text.begin(), text.end(), '\n', ' ');
  return text;
}

/// Without UseITK.cmake nothing registers ITK's IO factories: do it once,
/// explicitly, for image and transform files. Also keeps ITK/GDCM warnings
/// off stderr (the CLI's stderr is one line; errors come as exceptions).
void initializeItk() {
  static std::once_flag once;
  std::call_once(once, [] {
    itk::NrrdImageIOFactory::RegisterOneFactory();
    itk::NiftiImageIOFactory::RegisterOneFactory();
    itk::MetaImageIOFactory::RegisterOneFactory();
    itk::GDCMImageIOFactory::RegisterOneFactory();
    itk::TxtTransformIOFactory::RegisterOneFactory();
    itk::HDF5TransformIOFactory::RegisterOneFactory();
    itk::MatlabTransformIOFactory::RegisterOneFactory();
    itk::TransformFactoryBase::RegisterDefaultTransforms();
    itk::Object::GlobalWarningDisplayOff();
    // GDCM prints decoder errors (e.g. a truncated JPEG 2000 slice) to
    // stderr as well as failing; the failure reaches us as an ITK exception.
    gdcm::Trace::WarningOff();
    gdcm::Trace::ErrorOff();
    gdcm::Trace::DebugOff();
  });
}

const char* formatName(RawImageFormat format) {
  switch (format) {
    case RawImageFormat::Nrrd: return "NRRD";
    case RawImageFormat::Nifti: return "NIfTI";
    case RawImageFormat::MetaImage: return "MetaImage";
    case RawImageFormat::Dicom: return "DICOM";
  }
  return "image";
}

itk::ImageIOBase::Pointer makeImageIo(RawImageFormat format) {
  switch (format) {
    case RawImageFormat::Nrrd: return itk::NrrdImageIO::New().GetPointer();
    case RawImageFormat::Nifti: return itk::NiftiImageIO::New().GetPointer();
    case RawImageFormat::MetaImage: return itk::MetaImageIO::New().GetPointer();
    case RawImageFormat::Dicom: return itk::GDCMImageIO::New().GetPointer();
  }
  return nullptr;
}

RawComponent rawComponent(itk::IOComponentEnum component, const std::filesystem::path& path) {
  using C = itk::IOComponentEnum;
  switch (component) {
    case C::UCHAR: return RawComponent::UInt8;
    case C::CHAR: return RawComponent::Int8;
    case C::USHORT: return RawComponent::UInt16;
    case C::SHORT: return RawComponent::Int16;
    case C::UINT: return RawComponent::UInt32;
    case C::INT: return RawComponent::Int32;
    case C::FLOAT: return RawComponent::Float32;
    case C::DOUBLE: return RawComponent::Float64;
    case C::LONG:
    case C::LONGLONG: return RawComponent::Int64;
    case C::ULONG:
    case C::ULONGLONG: return RawComponent::UInt64;
    default: break;
  }
  throw UnsupportedError("image " + quoted(path) + " has voxel type '" +
                         itk::ImageIOBase::GetComponentTypeAsString(component) +
                         "', which MR-SNS does not support: convert it to an integer or float type");
}

itk::IOComponentEnum itkComponent(RawComponent component) {
  using C = itk::IOComponentEnum;
  switch (component) {
    case RawComponent::UInt8: return C::UCHAR;
    case RawComponent::Int8: return C::CHAR;
    case RawComponent::UInt16: return C::USHORT;
    case RawComponent::Int16: return C::SHORT;
    case RawComponent::UInt32: return C::UINT;
    case RawComponent::Int32: return C::INT;
    case RawComponent::Float32: return C::FLOAT;
    case RawComponent::Float64: return C::DOUBLE;
    case RawComponent::Int64: return C::LONGLONG;
    case RawComponent::UInt64: return C::ULONGLONG;
  }
  return C::UCHAR;
}

RawImage readRawImageUnguarded(RawImageFormat format, const std::filesystem::path& path) {
  const std::string file = path.string();
  itk::ImageIOBase::Pointer io = makeImageIo(format);
  if (!io->CanReadFile(file.c_str())) {
    throw FormatError("image " + quoted(path) + " is not a readable " + formatName(format) +
                      " file (its header was not recognised)");
  }
  io->SetFileName(file);
  io->ReadImageInformation();
  const unsigned dims = io->GetNumberOfDimensions();
  if (io->GetNumberOfComponents() != 1) {
    throw UnsupportedError("image " + quoted(path) + " has " + std::to_string(io->GetNumberOfComponents()) +
                           " components per voxel: only scalar images are supported");
  }
  if (dims < 2 || dims > 4 || (dims == 4 && io->GetDimensions(3) != 1)) {
    throw UnsupportedError("image " + quoted(path) + " has " + std::to_string(dims) +
                           " dimensions: only 2D and 3D images are supported");
  }
  RawImage image;
  image.dimensions = std::min(dims, 3U);
  image.component = rawComponent(io->GetComponentType(), path);
  for (unsigned axis = 0; axis < image.dimensions; ++axis) {
    const auto extent = io->GetDimensions(axis);
    if (extent == 0 || extent > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
      throw FormatError("image " + quoted(path) + " declares an invalid size along axis " + std::to_string(axis));
    }
    image.size[axis] = extent;
    image.spacing[axis] = io->GetSpacing(axis);
    image.origin[axis] = io->GetOrigin(axis);
    const std::vector<double> column = io->GetDirection(axis);
    for (std::size_t row = 0; row < std::min<std::size_t>(column.size(), 3); ++row) {
      image.direction[row * 3 + axis] = column[row];
    }
  }
  itk::ImageIORegion region(dims);
  for (unsigned axis = 0; axis < dims; ++axis) {
    region.SetIndex(axis, 0);
    region.SetSize(axis, io->GetDimensions(axis));
  }
  io->SetIORegion(region);
  image.data.resize(io->GetImageSizeInBytes());
  io->Read(image.data.data());
  return image;
}

}  // namespace

RawImage readRawImage(RawImageFormat format, const std::filesystem::path& path) {
  initializeItk();
  try {
    return readRawImageUnguarded(format, path);
  } catch (const itk::ExceptionObject& e) {
    throw FormatError("image " + quoted(path) + " could not be read as " + formatName(format) + ": " + itkMessage(e));
  } catch (const std::bad_alloc&) {
    throw FormatError("image " + quoted(path) + " declares more voxels than fit in memory: its header is corrupt");
  } catch (const std::length_error&) {
    throw FormatError("image " + quoted(path) + " declares more voxels than fit in memory: its header is corrupt");
  }
}

void writeRawImage(const RawImage& image, const std::vector<std::byte>& data, RawImageFormat format,
                   const std::filesystem::path& path, bool compress) {
  initializeItk();
  itk::ImageIOBase::Pointer io = makeImageIo(format);
  io->SetNumberOfDimensions(3);
  itk::ImageIORegion region(3);
  for (unsigned axis = 0; axis < 3; ++axis) {
    io->SetDimensions(axis, static_cast<unsigned>(image.size[axis]));
    io->SetSpacing(axis, image.spacing[axis]);
    io->SetOrigin(axis, image.origin[axis]);
    std::vector<double> column(3);
    for (std::size_t row = 0; row < 3; ++row) column[row] = image.direction[row * 3 + axis];
    io->SetDirection(axis, column);
    region.SetIndex(axis, 0);
    region.SetSize(axis, image.size[axis]);
  }
  io->SetPixelType(itk::IOPixelEnum::SCALAR);
  io->SetComponentType(itkComponent(image.component));
  io->SetNumberOfComponents(1);
  io->SetUseCompression(compress);
  io->SetIORegion(region);
  io->SetFileName(path.string());
  try {
    io->WriteImageInformation();
    io->Write(data.data());
  } catch (const itk::ExceptionObject& e) {
    throw FileError("writing image " + quoted(path) + " failed: " + itkMessage(e) +
                    " (check the folder exists and is writable)");
  }
}

DicomTags readDicomTags(const std::filesystem::path& file) {
  initializeItk();
  const gdcm::Tag series_uid(0x0020, 0x000e), description(0x0008, 0x103e), modality(0x0008, 0x0060),
      number(0x0020, 0x0011), rows(0x0028, 0x0010), columns(0x0028, 0x0011), patient_id(0x0010, 0x0020),
      patient_name(0x0010, 0x0010), study_date(0x0008, 0x0020), body_part(0x0018, 0x0015);
  gdcm::Reader reader;
  reader.SetFileName(file.string().c_str());
  // The header only, up to the largest tag wanted: never the pixel data.
  const std::set<gdcm::Tag> wanted = {series_uid, description, modality,     number,     rows,
                                      columns,    patient_id,  patient_name, study_date, body_part};
  if (!reader.ReadSelectedTags(wanted)) {
    throw FormatError("DICOM file " + quoted(file) + " could not be read: it is not a DICOM file or it is damaged");
  }
  gdcm::StringFilter filter;
  filter.SetFile(reader.GetFile());
  const gdcm::DataSet& data = reader.GetFile().GetDataSet();
  auto text = [&](const gdcm::Tag& tag) -> std::string {
    if (!data.FindDataElement(tag) || data.GetDataElement(tag).IsEmpty()) return {};
    std::string value = filter.ToString(tag);
    // DICOM pads to an even length with spaces (UI with NUL).
    const auto keep = [](char c) { return c != '\0' && !std::isspace(static_cast<unsigned char>(c)); };
    value.erase(std::find_if(value.rbegin(), value.rend(), keep).base(), value.end());
    value.erase(value.begin(), std::find_if(value.begin(), value.end(), keep));
    return value;
  };
  auto integer = [&](const gdcm::Tag& tag) {
    const std::string value = text(tag);
    try {
      return value.empty() ? 0 : std::stoi(value);
    } catch (const std::exception&) {
      return 0;  // a malformed count is reported as absent; the image reader checks the real size
    }
  };
  DicomTags tags;
  tags.series_instance_uid = text(series_uid);
  tags.series_description = text(description);
  tags.modality = text(modality);
  tags.series_number = text(number);
  tags.rows = integer(rows);
  tags.columns = integer(columns);
  tags.patient_id = text(patient_id);
  tags.patient_name = text(patient_name);
  tags.study_date = text(study_date);
  tags.body_part = text(body_part);
  return tags;
}

std::vector<DicomSeriesFiles> findDicomSeries(const std::filesystem::path& folder) {
  initializeItk();
  std::vector<DicomSeriesFiles> result;
  try {
    auto names = itk::GDCMSeriesFileNames::New();
    names->SetUseSeriesDetails(true);
    names->SetDirectory(folder.string());
    for (const auto& uid : names->GetSeriesUIDs()) {
      DicomSeriesFiles series;
      series.uid = uid;
      series.files = names->GetFileNames(uid);
      if (series.files.empty()) continue;
      result.push_back(std::move(series));
    }
  } catch (const itk::ExceptionObject& e) {
    throw FormatError("DICOM folder " + quoted(folder) + " could not be scanned: " + itkMessage(e));
  }
  for (auto& series : result) series.tags = readDicomTags(series.files.front());
  return result;
}

std::vector<RawTransform> readRawTransforms(const std::filesystem::path& path) {
  initializeItk();
  using TransformBase = itk::TransformBaseTemplate<double>;
  using Linear = itk::MatrixOffsetTransformBase<double, 3, 3>;
  using Composite = itk::CompositeTransform<double, 3>;
  std::vector<RawTransform> result;
  auto append = [&result](const TransformBase* t) {
    RawTransform raw;
    raw.class_name = t->GetTransformTypeAsString();
    const auto& p = t->GetParameters();
    raw.parameters.assign(p.begin(), p.end());
    const auto& f = t->GetFixedParameters();
    raw.fixed_parameters.assign(f.begin(), f.end());
    if (const auto* linear = dynamic_cast<const Linear*>(t)) {
      raw.linear = true;
      const auto& m = linear->GetMatrix();
      const auto& o = linear->GetOffset();
      for (unsigned r = 0; r < 3; ++r) {
        for (unsigned c = 0; c < 3; ++c) raw.matrix[r * 3 + c] = m(r, c);
        raw.offset[r] = o[r];
      }
    }
    result.push_back(std::move(raw));
  };
  try {
    auto reader = itk::TransformFileReaderTemplate<double>::New();
    reader->SetFileName(path.string());
    reader->Update();
    const auto* list = reader->GetTransformList();
    if (list == nullptr || list->empty()) {
      throw FormatError("transform file " + quoted(path) + " holds no transform");
    }
    const TransformBase* first = list->front().GetPointer();
    if (const auto* composite = dynamic_cast<const Composite*>(first)) {
      // The queue's last transform is applied first.
      const auto& queue = composite->GetTransformQueue();
      for (auto it = queue.rbegin(); it != queue.rend(); ++it) append(it->GetPointer());
      if (queue.empty()) throw FormatError("transform file " + quoted(path) + " holds an empty composite transform");
    } else {
      for (const auto& t : *list) append(t.GetPointer());
    }
  } catch (const itk::ExceptionObject& e) {
    throw FormatError("transform file " + quoted(path) + " could not be read: " + itkMessage(e));
  }
  return result;
}

void writeRawAffine(const std::array<double, 9>& matrix, const std::array<double, 3>& offset,
                    const std::filesystem::path& path) {
  initializeItk();
  using Affine = itk::AffineTransform<double, 3>;
  auto affine = Affine::New();
  Affine::MatrixType m;
  Affine::OutputVectorType o;
  for (unsigned r = 0; r < 3; ++r) {
    for (unsigned c = 0; c < 3; ++c) m(r, c) = matrix[r * 3 + c];
    o[r] = offset[r];
  }
  affine->SetMatrix(m);
  affine->SetOffset(o);
  try {
    auto writer = itk::TransformFileWriterTemplate<double>::New();
    writer->SetInput(affine);
    writer->SetFileName(path.string());
    writer->Update();
  } catch (const itk::ExceptionObject& e) {
    throw FileError("writing transform file " + quoted(path) + " failed: " + itkMessage(e) +
                    " (check the folder exists and is writable)");
  }
}

}  // namespace mrsns::io::detail
