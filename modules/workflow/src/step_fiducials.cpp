// find-fiducials and place-fiducial: the fiducials of the patient in the CT
// (image space), found on a screw or marker label, on metal in the CT, read
// from a markups file, or placed by the user; the set the registration pairs
// with the touched points.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/ct_bone_segmentation.h"
#include "mrsns/registration/fiducials_from_mesh.h"
#include "patient_data.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFiducialsFile = "fiducials/Fiducials.mrk.json";

/// Every bone model of the session in one mesh (the surface the screws enter).
TriangleMesh sessionBone(const Session& session, const std::string& step) {
  std::vector<TriangleMesh> meshes;
  for (const auto& m : session.models(ModelRole::Bone)) meshes.push_back(io::readMesh(session.resolve(m.file)));
  if (meshes.empty()) {
    throw InvalidArgumentError(step + ": the session has no bone model: make the bone models first (make-models "
                                      "from the vertebra labels or a bone threshold); a fiducial is where its screw "
                                      "enters the bone");
  }
  TriangleMesh bone = mergeMeshes(meshes);
  bone.name = "bone";
  bone.frame = "CT";
  return bone;
}

/// Writes the set's Slicer markups copy and stores it.
void storeFiducials(Session& session, FiducialSet set, std::vector<std::string>& outputs) {
  LandmarkSet landmarks;
  landmarks.name = "Fiducials";
  landmarks.frame = "CT";
  for (const auto& point : set.points) {
    Landmark l;
    l.label = point.label;
    l.position = point.position_ct;
    std::ostringstream d;
    d << "source=" << point.source;
    if (std::isfinite(point.confidence)) d << "; confidence=" << point.confidence;
    l.description = d.str();
    landmarks.points.push_back(l);
  }
  fs::create_directories(session.resolve("fiducials"));
  set.file = kFiducialsFile;
  if (!landmarks.points.empty()) {
    io::writeLandmarks(landmarks, session.resolve(set.file));
    outputs.push_back(set.file);
  } else {
    std::error_code ec;
    fs::remove(session.resolve(set.file), ec);
  }
  session.setFiducials(set);
}

Json pointsJson(const FiducialSet& set) {
  Json list = Json::array();
  for (const auto& p : set.points) {
    Json j = {{"label", p.label}, {"position_ct", {p.position_ct.x(), p.position_ct.y(), p.position_ct.z()}},
              {"source", p.source}};
    if (std::isfinite(p.confidence)) j["confidence"] = p.confidence;
    list.push_back(j);
  }
  return list;
}

std::string nextLabel(const FiducialSet& set) {
  for (int n = 1;; ++n) {
    const std::string label = "F-" + std::to_string(n);
    if (std::none_of(set.points.begin(), set.points.end(), [&](const FiducialPoint& p) { return p.label == label; })) {
      return label;
    }
  }
}

}  // namespace

StepResult runFindFiducials(Session& session, const Json& params, const StepContext& context) {
  const Params p("find-fiducials", params,
                 {"source", "label_map", "label", "threshold_hu", "count", "min_voxels", "path"});
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("find-fiducials: import the patient's CT first (import-ct)");
  std::string source = p.text("source", "");
  if (source.empty()) {
    // A fiducial label when a label map has one, else metal in the CT.
    source = "threshold";
    for (const auto& map : session.labelMaps()) {
      for (const auto& l : map.labels) {
        if (l.role == "fiducial") source = "label";
      }
    }
  }
  StepResult result;
  FiducialSet set;
  set.provenance = madeBy("find-fiducials");
  if (source == "file") {
    const std::string path = p.text("path", "");
    if (path.empty()) throw InvalidArgumentError("find-fiducials: source=file needs path= a markups, FCSV or CSV file");
    const auto read = io::readLandmarksFile(path);
    const Eigen::AlignedBox3d bounds = ctBounds(*ct);
    for (const auto& l : read.landmarks.points) {
      if (bounds.exteriorDistance(l.position) > 0.0) {
        std::ostringstream out;
        out.precision(1);
        out << std::fixed << "find-fiducials: '" << l.label << "' of '" << path << "' lies "
            << bounds.exteriorDistance(l.position)
            << " mm outside the CT: the file is in another frame (its coordinate system is "
            << read.info.coordinate_system << ")";
        throw FormatError(out.str());
      }
      FiducialPoint point;
      point.label = l.label.empty() ? nextLabel(set) : l.label;
      point.position_ct = l.position;
      point.source = "file";
      set.points.push_back(point);
    }
    set.provenance = madeBy("find-fiducials", fs::absolute(path).string());
    result.figures["coordinate_system"] = read.info.coordinate_system;
  } else if (source == "label" || source == "threshold") {
    registration::FiducialScrewsInMaskOptions options;
    options.count = p.integer("count", 0);
    const int min_voxels = p.integer("min_voxels", 4);
    if (min_voxels < 1) throw InvalidArgumentError("find-fiducials: min_voxels must be >= 1");
    options.min_voxels = static_cast<std::size_t>(min_voxels);
    ImageVolume mask;
    if (source == "label") {
      const LabelMapEntry map = sessionLabelMap(session, p.text("label_map", ""), "find-fiducials");
      const std::string wanted = p.text("label", "");
      const LabelEntry* label = nullptr;
      for (const auto& l : map.labels) {
        const bool match = wanted.empty() ? l.role == "fiducial"
                                          : (l.name == wanted || std::to_string(l.value) == wanted);
        if (match) label = &l;
      }
      if (label == nullptr) {
        std::string list;
        for (const auto& l : map.labels) list += (list.empty() ? "" : ", ") + l.name + " (" + std::to_string(l.value) + ")";
        throw InvalidArgumentError("find-fiducials: label map '" + map.id + "' has " +
                                   (wanted.empty() ? std::string("no screw, fiducial or marker label")
                                                   : "no voxel of label '" + wanted + "'") +
                                   ": give label= one of " + list + ", or source=threshold (metal in the CT)");
      }
      context.report(0.1, "reading label map " + map.id);
      const ImageVolume labels = loadSessionLabelMap(session, map);
      mask = registration::labelMask(labels, {label->value});
      result.figures["label"] = {{"label_map", map.id}, {"value", label->value}, {"name", label->name}};
    } else {
      const double threshold = p.number("threshold_hu", 2000.0);
      const ImageVolume image = loadSessionCt(session, "find-fiducials");
      mask = image;
      mask.pixel_type = PixelType::UInt8;
      mask.data.assign(image.voxelCount(), std::byte{0});
      std::size_t above = 0;
      for (std::size_t i = 0; i < image.voxelCount(); ++i) {
        if (image.valueAtIndex(i) > threshold) {
          mask.data[i] = std::byte{1};
          ++above;
        }
      }
      if (above == 0) {
        throw ComputationError("find-fiducials: no voxel of the CT is above " + std::to_string(static_cast<int>(threshold)) +
                               " HU: it shows no metal screw (lower threshold_hu, use a fiducial label, or place the "
                               "fiducials by hand with place-fiducial)");
      }
      result.figures["threshold_hu"] = threshold;
    }
    checkCancel(context);
    context.report(0.3, "reading the bone models");
    const TriangleMesh bone = sessionBone(session, "find-fiducials");
    checkCancel(context);
    context.report(0.5, "finding the screws and where each enters the bone");
    const auto found = registration::findFiducialScrewsInMask(mask, bone, options);
    if (found.found.fiducials.size() < 3) {
      result.figures["warning"] = "fewer than 3 fiducials: a landmark registration needs at least 3";
    }
    Json details = Json::array();
    for (const auto& f : found.found.fiducials) {
      FiducialPoint point;
      point.label = f.label;
      point.position_ct = f.position;
      point.source = source;
      point.confidence = f.confidence;
      point.axis_ct = f.axis;
      set.points.push_back(point);
      details.push_back({{"label", f.label},
                         {"entry_from", f.entry_from},
                         {"confidence", f.confidence},
                         {"elongation", f.elongation},
                         {"voxels_in_cluster", f.vertex_count}});
    }
    result.figures["regions"] = found.regions;
    result.figures["details"] = details;
  } else {
    throw InvalidArgumentError("find-fiducials: source must be label (a screw or marker label), threshold (metal in "
                               "the CT) or file (a markups file), not '" + source + "'");
  }
  set.provenance.quality = {{"source", source}, {"points", set.points.size()}};
  storeFiducials(session, set, result.outputs);
  result.figures["source"] = source;
  result.figures["fiducials"] = pointsJson(set);
  result.ok = !set.points.empty();
  result.summary = std::to_string(set.points.size()) + " fiducial(s) from " + source;
  return result;
}

StepResult runPlaceFiducial(Session& session, const Json& params, const StepContext& /*context*/) {
  const Params p("place-fiducial", params, {"label", "position", "remove", "clear"});
  const auto ct = session.ct();
  if (!ct) throw InvalidArgumentError("place-fiducial: import the patient's CT first (import-ct)");
  FiducialSet set = session.fiducials().value_or(FiducialSet{});
  StepResult result;
  std::string summary;
  if (p.boolean("clear", false)) {
    set.points.clear();
    summary = "fiducials cleared";
  } else if (p.boolean("remove", false)) {
    const std::string label = p.text("label", "");
    const auto it = std::find_if(set.points.begin(), set.points.end(),
                                 [&](const FiducialPoint& f) { return f.label == label; });
    if (it == set.points.end()) {
      throw InvalidArgumentError("place-fiducial: there is no fiducial '" + label + "' to remove");
    }
    set.points.erase(it);
    summary = "removed fiducial " + label;
  } else {
    const Eigen::Vector3d position = pointParam(params, "position", "place-fiducial");
    const Eigen::AlignedBox3d bounds = ctBounds(*ct);
    if (bounds.exteriorDistance(position) > 0.0) {
      std::ostringstream out;
      out.precision(1);
      out << std::fixed << "place-fiducial: the point lies " << bounds.exteriorDistance(position)
          << " mm outside the CT: place it on the patient's image";
      throw InvalidArgumentError(out.str());
    }
    const std::string label = p.text("label", nextLabel(set));
    FiducialPoint point;
    point.label = label;
    point.position_ct = position;
    point.source = "placed";
    const auto it = std::find_if(set.points.begin(), set.points.end(),
                                 [&](const FiducialPoint& f) { return f.label == label; });
    if (it != set.points.end()) {
      *it = point;
      summary = "moved fiducial " + label;
    } else {
      set.points.push_back(point);
      summary = "placed fiducial " + label;
    }
  }
  if (set.provenance.source.empty()) set.provenance = madeBy("place-fiducial");
  set.provenance.source = "user";
  storeFiducials(session, set, result.outputs);
  result.figures["fiducials"] = pointsJson(set);
  result.ok = true;
  result.summary = summary + " (" + std::to_string(set.points.size()) + " in all)";
  return result;
}

}  // namespace mrsns::workflow::detail
