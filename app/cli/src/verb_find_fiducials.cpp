// `mrsns-cli find-fiducials`: fiducial screws located in CT meshes (k-means
// of the screw mesh, PCA axis, intersection with the bone surface).
#include <sstream>

#include "cli_context.h"
#include "json_vectors.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/fiducials_from_mesh.h"

namespace mrsns::cli {
namespace {

struct FindFiducialsOptions {
  std::string screws;
  std::string bone;
  int count = 0;
  std::string output;
  std::uint64_t seed = registration::KMeansOptions{}.seed;
};

Report run(const FindFiducialsOptions& options) {
  const auto screws = io::readMesh(options.screws);
  const auto bone = io::readMesh(options.bone);
  registration::FiducialsFromMeshOptions fo;
  fo.kmeans.seed = options.seed;
  const auto result = registration::findFiducialsFromMeshes(screws, bone, options.count, fo);

  Report report;
  report.json["verb"] = "find-fiducials";
  report.json["screws"] = options.screws;
  report.json["bone"] = options.bone;
  report.json["count"] = options.count;
  Json list = Json::array();
  std::ostringstream text;
  text << "Fiducials from " << options.screws << " on " << options.bone << '\n';
  for (const auto& f : result.fiducials) {
    list.push_back(Json{{"label", f.label},
                        {"position_mm", vectorJson(f.position)},
                        {"axis", vectorJson(f.axis)},
                        {"head_point_mm", vectorJson(f.head_point)},
                        {"axis_hits_bone", f.axis_hits_bone},
                        {"hit_distance_mm", f.hit_distance_mm},
                        {"vertex_count", f.vertex_count},
                        {"elongation", f.elongation},
                        {"size_balance", f.size_balance},
                        {"confidence", f.confidence}});
    text << "  " << f.label << ": " << f.position.transpose() << " mm, confidence " << f.confidence
         << (f.axis_hits_bone ? "" : " (axis misses the bone: screw-head end point)") << '\n';
  }
  report.json["fiducials"] = list;
  report.json["kmeans_inertia_mm2"] = result.clusters.inertia;
  if (!options.output.empty()) {
    io::writeLandmarks(registration::fiducialLandmarks(result, bone.frame), options.output);
    report.json["output"] = options.output;
    text << "  written: " << options.output << '\n';
  }
  report.text = text.str();
  return report;
}

}  // namespace

void registerFindFiducialsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  auto opts = std::make_shared<FindFiducialsOptions>();
  auto* sub = app.add_subcommand("find-fiducials",
                                 "Fiducial screws from CT meshes: k-means of the screw mesh into COUNT screws, PCA "
                                 "axis, its intersection with the bone surface as the landmark, with a confidence");
  sub->add_option("--screws", opts->screws, "mesh of the segmented fiducial screws")->required();
  sub->add_option("--bone", opts->bone, "bone surface mesh")->required();
  sub->add_option("--count", opts->count, "number of fiducial screws")->required()->check(CLI::PositiveNumber);
  sub->add_option("--seed", opts->seed, "k-means seed")->capture_default_str();
  sub->add_option("--output", opts->output, "write the landmarks (.mrk.json, .fcsv or .csv)");
  addJsonFlag(*sub, options);
  verbs.emplace_back(sub, [opts] { return run(*opts); });
}

}  // namespace mrsns::cli
