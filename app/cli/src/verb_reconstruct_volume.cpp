// `mrsns-cli reconstruct-volume`: a tracked ultrasound sweep compounded into
// a 3D volume in the Reference (or Phantom) frame, with the ImageToProbe of
// a configuration (e.g. written by calibrate-us --output-config).
#include <chrono>
#include <cmath>
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/image_chain.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "mrsns/ultrasound/volume_reconstruction.h"

namespace mrsns::cli {
namespace {

struct ReconstructOptions {
  std::string config, sequence, output, to = "Reference";
  double spacing_mm = 0.5, tracker_lag_ms = 0.0;
  int every = 1, hole_radius = 1;
};

Report run(const ReconstructOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const auto config = io::readDeviceSet(options.config);
  const auto image_to_probe = config.findTransform("Image", "Probe");
  if (!image_to_probe) {
    throw FormatError(options.config +
                      ": no ImageToProbe in CoordinateDefinitions; calibrate the probe first (calibrate-us "
                      "--output-config)");
  }
  Eigen::Matrix4d target_T_reference = Eigen::Matrix4d::Identity();
  if (options.to == "Phantom") {
    target_T_reference = ultrasound::phantomToReference(config).inverse().matrix();
  } else if (options.to != "Reference") {
    throw InvalidArgumentError("--to: '" + options.to + "' is not supported; use Reference or Phantom");
  }
  const auto sequence = io::readSequence(options.sequence);
  if (sequence.frames.empty()) throw FormatError(options.sequence + ": the sequence has no frames");
  const auto poses = extractFramePoses(sequence.frames, "ProbeToReference").poses;
  const double lag_s = options.tracker_lag_ms * 1e-3;
  const int w = sequence.geometry.size[0], h = sequence.geometry.size[1];

  struct Placed {
    std::size_t frame;
    Eigen::Matrix4d target_T_image;
  };
  std::vector<Placed> placed;
  std::vector<Eigen::Vector3d> corners;
  const double first = poses.empty() ? 0.0 : poses.front().timestamp,
               last = poses.empty() ? 0.0 : poses.back().timestamp;
  for (const auto& p : poses) {
    if ((p.frame_index % static_cast<std::size_t>(options.every)) != 0) continue;
    const double t = sequence.frames[p.frame_index].timestamp + lag_s;
    if (t < first || t > last) continue;
    const Eigen::Isometry3d reference_T_probe =
        ultrasound::probePoseAtVideoTime(poses, sequence.frames[p.frame_index].timestamp, lag_s);
    const Eigen::Matrix4d m = target_T_reference * reference_T_probe.matrix() * image_to_probe->to_T_from;
    placed.push_back({p.frame_index, m});
    for (const auto& [u, v] : {std::pair{0, 0}, {w - 1, 0}, {0, h - 1}, {w - 1, h - 1}}) {
      corners.push_back((m * Eigen::Vector4d(u, v, 0, 1)).head<3>());
    }
  }
  if (placed.empty()) {
    throw FrameError(options.sequence + ": no frame has a valid ProbeToReference at its (lag-shifted) time");
  }
  std::array<int, 4> clip{};
  if (config.segmentation) {
    const auto s = ultrasound::segmentationOptionsFrom(*config.segmentation);
    clip = {s.clip_x, s.clip_y, s.clip_width, s.clip_height};
  }
  ultrasound::VolumeReconstructor reconstructor(ultrasound::gridAroundCorners(corners, options.spacing_mm, 1.0));
  for (const auto& p : placed) {
    const auto pixels = ultrasound::toMfPixels(sequence, sequence.frames[p.frame]);
    reconstructor.addFrame({w, h, pixels}, p.target_T_image, clip);
  }
  ImageVolume volume = reconstructor.result(options.hole_radius);
  volume.frame = options.to;
  volume.name = "ultrasound";
  io::writeImage(volume, options.output);
  const auto& f = reconstructor.figures();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  Report report;
  report.json = Json{{"verb", "reconstruct-volume"},
                     {"output", options.output},
                     {"frame", options.to},
                     {"size", {volume.size[0], volume.size[1], volume.size[2]}},
                     {"spacing_mm", options.spacing_mm},
                     {"origin_mm", {volume.origin.x(), volume.origin.y(), volume.origin.z()}},
                     {"frames", f.frames},
                     {"frames_in_sequence", sequence.frames.size()},
                     {"tracker_lag_ms", options.tracker_lag_ms},
                     {"pixels_inside", f.pixels_inside},
                     {"pixels_outside", f.pixels_outside},
                     {"filled_fraction", f.filled_fraction},
                     {"holes_filled", f.holes_filled},
                     {"seconds", seconds}};
  std::ostringstream text;
  text << "volume " << volume.size[0] << " x " << volume.size[1] << " x " << volume.size[2] << " voxels of "
       << options.spacing_mm << " mm in " << options.to << " from " << f.frames << " frames, "
       << std::lround(100.0 * f.filled_fraction) << "% filled, written to " << options.output << "\n";
  report.text = text.str();
  return report;
}

}  // namespace

void registerReconstructVolumeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<ReconstructOptions>();
  auto* sub = app.add_subcommand(
      "reconstruct-volume",
      "compound a tracked ultrasound sweep into a 3D volume (trilinear splatting, mean compounding, hole filling)");
  sub->add_option("--config", opts->config, "PLUS device-set configuration with ImageToProbe (and PhantomToReference)")
      ->required();
  sub->add_option("--sequence", opts->sequence, "tracked B-mode sequence with ProbeToReference per frame")->required();
  sub->add_option("--out", opts->output, "output volume (.nrrd, .mha, .nii.gz)")->required();
  sub->add_option("--to", opts->to, "frame of the volume: Reference or Phantom")->default_val("Reference");
  sub->add_option("--spacing", opts->spacing_mm, "voxel size (mm)")->default_val(0.5)->check(CLI::PositiveNumber);
  sub->add_option("--tracker-lag-ms", opts->tracker_lag_ms, "tracker lag (PLUS TrackerLagSec convention, ms)")
      ->default_val(0.0);
  sub->add_option("--every", opts->every, "use every N-th frame")->default_val(1)->check(CLI::PositiveNumber);
  sub->add_option("--hole-radius", opts->hole_radius, "fill holes from neighbours within this many voxels (0: none)")
      ->default_val(1)
      ->check(CLI::Range(0, 5));
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
