// `mrsns-cli latency`: latency between two recordings of the same motion (tracker and HMD
// self-tracking), paper 000 §2.2 (hmd/latency.h), and what a predictor recovers of it.
#include <sstream>

#include "cli_context.h"
#include "mrsns/core/error.h"
#include "mrsns/hmd/latency.h"
#include "mrsns/hmd/latency_predictor.h"
#include "mrsns/io/pose_csv.h"

namespace mrsns::cli {
namespace {

struct LatencyVerbOptions {
  std::string tracker;
  std::string hmd;
  int component = 3;
  double max_latency_ms = 500.0;
};

std::vector<Eigen::Vector3d> positions(const io::PoseCsv& csv) {
  std::vector<Eigen::Vector3d> p;
  for (const auto& T : csv.poses) p.push_back(T.translation());
  return p;
}

io::PoseCsv readTimed(const std::string& path, const char* what) {
  io::PoseCsv csv = io::readPoseCsv(path);
  if (csv.timestamps.empty()) {
    throw FormatError(std::string(what) + " file '" + path +
                      "' has no timestamps; latency needs 17 columns per line (time in seconds, then the 4x4 "
                      "matrix row major)");
  }
  return csv;
}

Json prediction(const hmd::PredictionEvaluation& e) {
  return Json{{"samples", e.count},
              {"rms_translation_mm", e.rms_translation_predicted_mm},
              {"rms_rotation_deg", e.rms_rotation_predicted_rad * 180.0 / M_PI}};
}

Report run(const LatencyVerbOptions& o) {
  if (o.component < 1 || o.component > 3) {
    throw InvalidArgumentError("latency: --component must be 1, 2 or 3 (the paper uses 3)");
  }
  const io::PoseCsv tracker = readTimed(o.tracker, "tracker");
  const io::PoseCsv hmd_csv = readTimed(o.hmd, "HMD");
  hmd::LatencyOptions lo;
  lo.component = o.component - 1;
  lo.max_latency_s = o.max_latency_ms / 1000.0;
  const auto r =
      hmd::estimateLatency(tracker.timestamps, positions(tracker), hmd_csv.timestamps, positions(hmd_csv), lo);

  Report rep;
  rep.json["verb"] = "latency";
  rep.json["tracker"] = {{"file", o.tracker}, {"samples", tracker.poses.size()}};
  rep.json["hmd"] = {{"file", o.hmd}, {"samples", hmd_csv.poses.size()}};
  rep.json["component"] = o.component;
  rep.json["events"] = {{"count", r.events.size()},
                        {"latency_ms_mean", r.event_mean_s * 1000.0},
                        {"latency_ms_std", r.event_std_s * 1000.0},
                        {"latency_ms_median", r.event_median_s * 1000.0}};
  rep.json["cross_correlation"] = {{"latency_ms", r.xcorr_latency_s * 1000.0}, {"peak", r.xcorr_peak}};
  rep.json["component_sign_flipped"] = r.component_sign_flipped;
  rep.json["explained_variance"] = {
      {"tracker", {r.tracker_explained_variance(0), r.tracker_explained_variance(1), r.tracker_explained_variance(2)}},
      {"hmd", {r.hmd_explained_variance(0), r.hmd_explained_variance(1), r.hmd_explained_variance(2)}}};
  rep.json["grid_period_ms"] = r.grid_period_s * 1000.0;

  // How much of the measured latency a predictor would hide, replayed on the HMD's own stream.
  const double latency = std::max(0.0, r.event_median_s);
  const int warmup = 10;
  Json pred = Json::object();
  if (hmd_csv.poses.size() > static_cast<std::size_t>(warmup) + 2) {
    hmd::PredictorOptions cv;
    cv.model = hmd::PredictorModel::kConstantVelocity;
    const auto e_cv = hmd::evaluatePredictor(hmd_csv.timestamps, hmd_csv.poses, hmd_csv.poses, latency, cv, warmup);
    const auto e_kf = hmd::evaluatePredictor(hmd_csv.timestamps, hmd_csv.poses, hmd_csv.poses, latency, {}, warmup);
    pred["latency_ms"] = latency * 1000.0;
    pred["none"] = {{"samples", e_kf.count},
                    {"rms_translation_mm", e_kf.rms_translation_none_mm},
                    {"rms_rotation_deg", e_kf.rms_rotation_none_rad * 180.0 / M_PI}};
    pred["constant_velocity"] = prediction(e_cv);
    pred["kalman"] = prediction(e_kf);
  }
  rep.json["prediction"] = pred;
  std::ostringstream s;
  s.precision(4);
  s << "latency: " << r.events.size() << " events, " << r.event_mean_s * 1000.0 << " +/- " << r.event_std_s * 1000.0
    << " ms (median " << r.event_median_s * 1000.0 << " ms); cross-correlation " << r.xcorr_latency_s * 1000.0
    << " ms (peak " << r.xcorr_peak << ")\n";
  rep.text = s.str();
  return rep;
}

}  // namespace

void registerLatencyVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<LatencyVerbOptions>();
  auto* sub = app.add_subcommand("latency",
                                 "latency of the HMD's self-tracking against the tracker from two timed pose "
                                 "recordings of the same motion (paper 000 §2.2)");
  sub->add_option("--tracker", opts->tracker, "tracker poses CSV (time, then 16 values row major)")->required();
  sub->add_option("--hmd", opts->hmd, "HMD self-tracking poses CSV (same format)")->required();
  sub->add_option("--component", opts->component, "principal component compared, 1-3")->capture_default_str();
  sub->add_option("--max-latency-ms", opts->max_latency_ms, "largest latency searched (ms)")->capture_default_str();
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
