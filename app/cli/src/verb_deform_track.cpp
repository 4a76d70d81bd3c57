// `mrsns-cli deform-track`: a recorded tracked ultrasound sequence and a shape
// model -> the posterior shape per frame (paper 001 Algorithm 1), with the
// contours from the built-in B-mode lumen segmenter or from an external
// segmenter's contour file (format in modules/deformation/doc/README.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/deformation/bmode.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/io/transform_io.h"

namespace mrsns::cli {
namespace {

struct DeformTrackOptions {
  std::string model;
  std::string sequence;
  std::string calibration;
  std::string config;
  std::string contours;
  std::string out;
  std::string model_frame = "Reference";
  std::string format = "vtp";
  int every = 10;
  double sigma_mm = 1.5;
  double threshold_mm = 1.2;
  int contour_points = 15;
};

// probe_T_image in pixels (PLUS: the calibration carries the pixel scale).
Eigen::Matrix4d imageToProbe(const DeformTrackOptions& o) {
  if (!o.calibration.empty() && !o.config.empty()) {
    throw InvalidArgumentError("deform-track: give --calibration or --config, not both");
  }
  if (!o.calibration.empty()) {
    // The node ImageToProbe by io/transform_io.h's convention: a plain .txt is probe_T_image as written, an
    // ITK file (.tfm/.h5, as Slicer and us-spatial-calibration write it) holds its inverse.
    return io::readChildToParent(o.calibration);
  }
  if (!o.config.empty()) {
    const auto cfg = io::readDeviceSet(o.config);
    const auto t = cfg.findTransform("Image", "Probe");
    if (!t) throw FormatError("deform-track: " + o.config + " has no CoordinateDefinitions Transform Image -> Probe");
    return t->to_T_from;
  }
  throw InvalidArgumentError(
      "deform-track: give the ImageToProbe calibration (--calibration FILE or --config PLUS.xml)");
}

// External contours: {"frames": [{"frame": i, "contours": [[[x, y], ...], ...]}], "units": "mm"|"px"}
// or CSV lines "frame,contour,x,y" (image mm). Keyed by frame index.
std::map<int, std::vector<Polyline3d>> readContoursFile(const std::string& path, double pixel_mm) {
  std::ifstream in(path);
  if (!in) throw FileError("deform-track: cannot open the contours file " + path);
  std::map<int, std::vector<Polyline3d>> out;
  const bool csv = std::filesystem::path(path).extension() == ".csv";
  try {
    if (!csv) {
      const Json j = Json::parse(in);
      const double unit = j.value("units", std::string("mm")) == "px" ? pixel_mm : 1.0;
      for (const auto& fr : j.at("frames")) {
        auto& list = out[fr.at("frame").get<int>()];
        for (const auto& c : fr.at("contours")) {
          Polyline3d p;
          p.closed = true;
          for (const auto& q : c) {
            if (q.size() < 2) throw FormatError("a point needs x and y");
            p.points.emplace_back(unit * q[0].get<double>(), unit * q[1].get<double>(), 0.0);
          }
          list.push_back(std::move(p));
        }
      }
    } else {
      std::string line;
      std::map<std::pair<int, int>, Polyline3d> parts;
      int line_no = 0;
      while (std::getline(in, line)) {
        ++line_no;
        if (line.empty() || line[0] == '#' || std::isalpha(static_cast<unsigned char>(line[0]))) continue;
        std::replace(line.begin(), line.end(), ',', ' ');
        std::istringstream ls(line);
        int f = 0, c = 0;
        double x = 0, y = 0;
        if (!(ls >> f >> c >> x >> y))
          throw FormatError("line " + std::to_string(line_no) + " is not frame,contour,x,y");
        auto& p = parts[{f, c}];
        p.closed = true;
        p.points.emplace_back(x, y, 0.0);
      }
      for (auto& [key, p] : parts) out[key.first].push_back(std::move(p));
    }
  } catch (const Json::exception& e) {
    throw FormatError("deform-track: contours file " + path + " is not valid: " + e.what());
  } catch (const FormatError& e) {
    throw FormatError("deform-track: contours file " + path + ": " + e.what());
  }
  for (const auto& [f, list] : out) {
    for (const auto& c : list) {
      for (const auto& p : c.points) {
        if (!p.allFinite()) throw FormatError("deform-track: contours file " + path + " holds a non-finite point");
      }
    }
  }
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(
      std::clamp(q * static_cast<double>(v.size() - 1), 0.0, static_cast<double>(v.size() - 1)))];
}

Report run(const DeformTrackOptions& o) {
  if (o.every < 1) throw InvalidArgumentError("deform-track: --every must be >= 1");
  if (o.format != "vtp" && o.format != "stl" && o.format != "vtk" && o.format != "ply") {
    throw InvalidArgumentError("deform-track: --format must be vtp, stl, vtk or ply");
  }
  const ShapeModel model = io::readStatismoModel(o.model);
  deformation::validateShapeModel(model, o.model);
  const Eigen::Matrix4d probe_T_image_px = imageToProbe(o);
  io::SequenceReader reader(o.sequence);
  const TrackedSequence& header = reader.header();
  if (header.geometry.dimensions != 2 || header.pixel_format.components != 1 ||
      header.pixel_format.scalar != PixelType::UInt8) {
    throw UnsupportedError("deform-track: " + o.sequence + " must hold 2D 8-bit single-component B-mode frames");
  }
  // Image coordinates of Algorithm 1 are mm; the calibration's column norms
  // are the pixel size when it carries the scale (PLUS), 1 when it does not.
  const Eigen::Vector3d col = probe_T_image_px.topLeftCorner<3, 3>().colwise().norm();
  const bool has_scale = std::abs(col.x() - 1.0) > 1e-3;
  const double pixel_mm = has_scale ? col.x() : header.geometry.spacing[0];
  if (!(pixel_mm > 0.0) || std::abs(col.y() - col.x()) > 1e-3 * col.x()) {
    throw UnsupportedError("deform-track: the calibration's pixel scale must be isotropic in x and y");
  }
  Eigen::Matrix4d unscale = Eigen::Matrix4d::Identity();
  if (has_scale) unscale.diagonal().head<3>() = col.cwiseInverse();
  Eigen::Isometry3d probe_T_image = Eigen::Isometry3d::Identity();
  {
    const Eigen::Matrix4d m = probe_T_image_px * unscale;
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(), Eigen::ComputeFullU | Eigen::ComputeFullV);
    probe_T_image.linear() = svd.matrixU() * svd.matrixV().transpose();
    probe_T_image.translation() = m.topRightCorner<3, 1>();
  }
  std::map<int, std::vector<Polyline3d>> external;
  if (!o.contours.empty()) external = readContoursFile(o.contours, pixel_mm);

  deformation::ShapeTrackerOptions topt;
  topt.posterior.noise_sigma_mm = o.sigma_mm;
  topt.update_threshold_mm = o.threshold_mm;
  topt.contour_points = o.contour_points;
  deformation::PosteriorShapeTracker tracker(model, topt);
  std::filesystem::create_directories(o.out);

  const std::size_t n = reader.frameCount();
  int used = 0, refused = 0, segmented = 0, contours_refused = 0, external_frames = 0;
  std::map<std::string, int> refusals;
  std::vector<double> update_ms, seg_ms;
  Json meshes = Json::array();
  const auto write = [&](std::size_t f) {
    const auto file = std::filesystem::path(o.out) / ("posterior_" + std::to_string(f) + "." + o.format);
    io::writeMesh(tracker.currentMesh(), file);
    meshes.push_back({{"frame", f}, {"file", file.string()}});
  };
  for (std::size_t f = 0; f < n; ++f) {
    const TrackedFrame frame = reader.readFrame(f);
    TransformRepository repo;
    for (const auto& [name, t] : frame.transforms) {
      if (t.status != TransformStatus::Ok) continue;
      Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(t.matrix.topLeftCorner<3, 3>(),
                                                  Eigen::ComputeFullU | Eigen::ComputeFullV);
      iso.linear() = svd.matrixU() * svd.matrixV().transpose();
      iso.translation() = t.matrix.topRightCorner<3, 1>();
      repo.setTransform(name, iso);
    }
    repo.setTransform("Image", "Probe", probe_T_image);
    const auto model_T_image = repo.getTransform("Image", o.model_frame);
    std::string why;
    if (frame.image_status != "OK") why = "image status " + frame.image_status;
    if (why.empty() && !model_T_image.ok()) why = "no valid Image -> " + o.model_frame + " chain";
    std::vector<Polyline3d> features;
    if (why.empty()) {
      if (!o.contours.empty()) {
        const auto it = external.find(static_cast<int>(f));
        if (it != external.end()) {
          features = it->second;
          ++external_frames;
        }
      } else {
        const auto t0 = std::chrono::steady_clock::now();
        deformation::BModeImage image;
        image.width = static_cast<int>(header.geometry.size[0]);
        image.height = static_cast<int>(header.geometry.size[1]);
        image.spacing_mm = pixel_mm;
        image.pixels.resize(frame.pixels.size());
        std::transform(frame.pixels.begin(), frame.pixels.end(), image.pixels.begin(),
                       [](std::uint8_t v) { return static_cast<float>(v) / 128.0f; });
        const auto seeds = tracker.predictedContours(model_T_image.to_T_from);
        for (const auto& l : deformation::segmentLumens(image, seeds)) {
          if (l.ok) {
            features.push_back(l.contour);
            ++segmented;
          } else {
            ++contours_refused;
          }
        }
        seg_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      }
      const deformation::FrameUpdate u = tracker.update(model_T_image.to_T_from, features);
      if (u.updated) {
        ++used;
        update_ms.push_back(u.elapsed_ms);
      } else {
        why = u.status;
      }
    }
    if (!why.empty()) {
      ++refused;
      ++refusals[why];
    }
    if ((f + 1) % static_cast<std::size_t>(o.every) == 0 || f + 1 == n) write(f);
  }
  const auto& post = tracker.posterior();
  Report r;
  r.json["verb"] = "deform-track";
  r.json["model"] = o.model;
  r.json["sequence"] = o.sequence;
  r.json["contour_source"] = o.contours.empty() ? "bmode-segmenter" : o.contours;
  r.json["frames"] = n;
  r.json["frames_used"] = used;
  r.json["frames_refused"] = refused;
  Json why = Json::object();
  for (const auto& [k, v] : refusals) why[k] = v;
  r.json["refusals"] = why;
  r.json["contours_segmented"] = segmented;
  r.json["contours_refused"] = contours_refused;
  r.json["frames_with_external_contours"] = external_frames;
  r.json["pixel_mm"] = pixel_mm;
  r.json["observations"] = tracker.observations().size();
  r.json["excluded"] = post.excluded.size();
  r.json["mahalanobis"] = post.mahalanobis;
  r.json["plausible"] = post.plausible;
  r.json["rms_residual_mm"] = post.rms_residual_mm;
  r.json["mean_displacement_from_prior_mm"] = deformation::meanVertexDistance(tracker.currentShape(), model.mean);
  r.json["update_ms"] = {{"p50", percentile(update_ms, 0.5)}, {"p99", percentile(update_ms, 0.99)}};
  r.json["segmentation_ms"] = {{"p50", percentile(seg_ms, 0.5)}, {"p99", percentile(seg_ms, 0.99)}};
  r.json["meshes"] = meshes;
  std::ostringstream t;
  t << "deform-track: " << n << " frames, " << used << " used, " << refused << " refused; Mahalanobis "
    << post.mahalanobis << (post.plausible ? "" : " (implausible)") << "; update p50 " << percentile(update_ms, 0.5)
    << " ms, p99 " << percentile(update_ms, 0.99) << " ms; " << meshes.size() << " meshes in " << o.out << "\n";
  r.text = t.str();
  return r;
}

}  // namespace

void registerDeformTrackVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto o = std::make_shared<DeformTrackOptions>();
  auto* sub = app.add_subcommand("deform-track",
                                 "posterior shape per frame from a tracked ultrasound sequence and a shape model "
                                 "(paper 001 Algorithm 1)");
  sub->add_option("--model", o->model, "statismo .h5 shape model, in the --model-frame frame")->required();
  sub->add_option("--sequence", o->sequence, "PLUS tracked sequence (.igs.mha, .mha, .seq.nrrd)")->required();
  sub->add_option(
      "--calibration", o->calibration,
      "the calibration ImageToProbe (probe_T_image in pixels): a plain 4x4 .txt, or an ITK .tfm/.h5 as Slicer and "
      "us-spatial-calibration write it (the inverse)");
  sub->add_option("--config", o->config, "PLUS configuration with CoordinateDefinitions Image -> Probe");
  sub->add_option("--contours", o->contours,
                  "external segmenter contours per frame (.json or .csv; see deformation doc) instead of the "
                  "built-in B-mode segmenter");
  sub->add_option("--out", o->out, "output directory for the posterior meshes")->required();
  sub->add_option("--model-frame", o->model_frame, "frame of the model in the sequence's transforms")
      ->capture_default_str();
  sub->add_option("--every", o->every, "write the posterior every N frames (and the last)")->capture_default_str();
  sub->add_option("--format", o->format, "mesh format: vtp, stl, vtk, ply")->capture_default_str();
  sub->add_option("--sigma", o->sigma_mm, "posterior observation noise sigma (mm)")->capture_default_str();
  sub->add_option("--threshold", o->threshold_mm, "D^Thr of Algorithm 1 (mm)")->capture_default_str();
  sub->add_option("--contour-points", o->contour_points, "K of Algorithm 1")->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [o] { return run(*o); });
}

}  // namespace mrsns::cli
