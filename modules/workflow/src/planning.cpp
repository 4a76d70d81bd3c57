// Screw planning on the session's anatomy (planning.h).
#include "mrsns/workflow/planning.h"

#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/registration/screw_planning.h"

namespace mrsns::workflow {

using Json = nlohmann::json;

namespace {

/// Position of a vertebra along the spine, C1 = 0 downwards (T13 and L6 counted where they sit).
std::optional<int> spineIndex(const std::string& vertebra) {
  if (vertebra.size() < 2) return std::nullopt;
  const int n = std::stoi(vertebra.substr(1));
  switch (vertebra[0]) {
    case 'C': return n - 1;
    case 'T': return 7 + n - 1;
    case 'L': return 20 + n - 1;
    case 'S': return 26 + n - 1;
    default: return std::nullopt;
  }
}

registration::StructureKind kindOf(ModelRole role) {
  switch (role) {
    case ModelRole::Vessel: return registration::StructureKind::Vessel;
    case ModelRole::SoftTissue: return registration::StructureKind::SoftTissue;
    case ModelRole::Neural: return registration::StructureKind::Neural;
    default: return registration::StructureKind::Other;
  }
}

Json vec3(const Eigen::Vector3d& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

Json number(double v) {
  return std::isfinite(v) ? Json(v) : Json(nullptr);
}

}  // namespace

struct PlanningAnatomyCache::Impl {
  struct Loaded {
    std::string name;
    ModelRole role = ModelRole::Other;
    std::string vertebra;
    TriangleMesh mesh;
    std::unique_ptr<MeshLocator> locator;
    std::optional<registration::VertebraFrame> frame;
  };
  std::vector<Loaded> models;
  registration::PlanningAnatomy anatomy;
  std::vector<std::string> warnings;
};

PlanningAnatomyCache::PlanningAnatomyCache(const Session& session) : impl_(std::make_unique<Impl>()) {
  for (const auto& m : session.models()) {
    if (m.role == ModelRole::Fiducial) continue;
    Impl::Loaded l;
    l.name = m.name;
    l.role = m.role;
    l.vertebra = m.vertebra;
    l.mesh = io::readMesh(session.resolve(m.file));
    if (l.mesh.faceCount() == 0) continue;
    if (m.role == ModelRole::Bone && !isClosed(l.mesh)) {
      impl_->warnings.push_back("bone model " + m.name +
                                " is not a closed surface: the screws' cortical breach cannot be measured on it");
      continue;
    }
    l.locator = std::make_unique<MeshLocator>(l.mesh);
    impl_->models.push_back(std::move(l));
  }
  // Each vertebra's superior axis from its neighbours' centroids where the session has them: a vertebra's own
  // inertia says little about which way the spine runs through it.
  std::map<int, Eigen::Vector3d> centroids;
  for (const auto& l : impl_->models) {
    if (l.role != ModelRole::Bone || l.vertebra.empty()) continue;
    if (const auto index = spineIndex(l.vertebra)) centroids[*index] = surfaceCentroid(l.mesh);
  }
  for (auto& l : impl_->models) {
    if (l.role == ModelRole::Bone) {
      registration::BoneStructure b;
      b.name = l.name;
      b.surface = l.locator.get();
      if (!l.vertebra.empty()) {
        registration::VertebraFrameOptions options;
        if (const auto index = spineIndex(l.vertebra)) {
          const auto above = centroids.find(*index - 1), below = centroids.find(*index + 1);
          const Eigen::Vector3d here = centroids.at(*index);
          if (above != centroids.end() && below != centroids.end()) {
            options.superior_hint = above->second - below->second;
          } else if (above != centroids.end()) {
            options.superior_hint = above->second - here;
          } else if (below != centroids.end()) {
            options.superior_hint = here - below->second;
          }
        }
        try {
          l.frame = registration::vertebraFrame(l.mesh, options);
        } catch (const InvalidArgumentError&) {
          options.superior_hint.reset();  // neighbours placed oddly (a gap, a scoliosis): the vertebra alone
          try {
            l.frame = registration::vertebraFrame(l.mesh, options);
          } catch (const InvalidArgumentError& e) {
            impl_->warnings.push_back("vertebra " + l.name + " has no anatomical frame (" + e.what() +
                                      "): its screws' angles are not given");
          }
        }
        if (l.frame) {
          for (const auto& w : l.frame->warnings) impl_->warnings.push_back("vertebra " + l.name + ": " + w);
        }
        b.frame = l.frame;
      }
      impl_->anatomy.vertebrae.push_back(std::move(b));
    } else {
      registration::AvoidanceStructure a;
      a.name = l.name;
      a.kind = kindOf(l.role);
      a.surface = l.locator.get();
      impl_->anatomy.avoidance.push_back(std::move(a));
    }
  }
}

PlanningAnatomyCache::~PlanningAnatomyCache() = default;

std::vector<std::string> PlanningAnatomyCache::vertebrae() const {
  std::vector<std::string> out;
  for (const auto& v : impl_->anatomy.vertebrae) out.push_back(v.name);
  return out;
}

std::vector<std::string> PlanningAnatomyCache::structures() const {
  std::vector<std::string> out;
  for (const auto& a : impl_->anatomy.avoidance) out.push_back(a.name);
  return out;
}

const std::vector<std::string>& PlanningAnatomyCache::warnings() const {
  return impl_->warnings;
}

Json PlanningAnatomyCache::evaluate(const PlannedScrew& screw) const {
  registration::ScrewPath path;
  path.name = screw.name;
  path.vertebra = screw.vertebra;
  path.entry = screw.entry;
  path.target = screw.target;
  path.diameter_mm = screw.diameter_mm;
  path.length_mm = screw.length_mm;
  registration::validateScrewPath(path);
  const auto f = registration::evaluateScrewPlan(path, impl_->anatomy);
  Json out;
  out["length_mm"] = path.effectiveLength();
  out["diameter_mm"] = path.diameter_mm;
  out["tip"] = vec3(path.tip());
  out["vertebra"] = f.vertebra.empty() ? Json(nullptr) : Json(f.vertebra);
  out["vertebra_from"] = std::string(registration::vertebraSourceName(f.vertebra_from));
  if (f.angles) {
    const auto& a = *f.angles;
    out["angles"] = {{"medial_deg", number(a.medial_deg)},
                     {"cranial_deg", number(a.cranial_deg)},
                     {"axial_deg", number(a.axial_deg)},
                     {"side", a.side},
                     {"points_posteriorly", a.points_posteriorly}};
  } else {
    out["angles"] = nullptr;
  }
  if (f.breach) {
    const auto& b = *f.breach;
    out["breach"] = {{"max_breach_mm", b.max_breach_mm},
                     {"grade", std::string(1, b.grade_letter)},
                     {"depth_of_max_breach_mm", b.depth_of_max_breach_mm},
                     {"axis_outside_mm", b.axis_outside_mm},
                     {"surface_outside_mm", b.surface_outside_mm},
                     {"length_in_bone_mm", b.length_in_bone_mm},
                     {"entry_to_bone_mm", b.entry_to_bone_mm}};
  } else {
    out["breach"] = nullptr;
  }
  Json clearance = Json::object();
  for (std::size_t k = 0; k < registration::kStructureKindCount; ++k) {
    const auto& c = f.by_kind[k];
    const std::string kind(registration::structureKindName(static_cast<registration::StructureKind>(k)));
    if (!c.min_clearance_mm) {
      clearance[kind] = nullptr;
      continue;
    }
    const auto& s = f.clearances.at(*c.closest);
    clearance[kind] = {{"name", *c.name},
                       {"min_clearance_mm", *c.min_clearance_mm},
                       {"depth_mm", s.depth_mm},
                       {"cuts", c.cuts},
                       {"structures", c.structures}};
  }
  out["clearance"] = clearance;
  Json structures = Json::array();
  for (const auto& s : f.clearances) {
    structures.push_back({{"name", s.name},
                          {"kind", std::string(registration::structureKindName(s.kind))},
                          {"min_clearance_mm", s.min_clearance_mm},
                          {"depth_mm", s.depth_mm},
                          {"cuts", s.cuts}});
  }
  out["structures"] = structures;
  out["warnings"] = f.warnings;
  return out;
}

std::string plannedScrewDescription(const PlannedScrew& screw) {
  registration::ScrewPath path;
  path.vertebra = screw.vertebra;
  path.diameter_mm = screw.diameter_mm;
  path.length_mm = screw.length_mm;
  std::string text = registration::screwPathDescription(path);
  if (!screw.side.empty()) text += "; side=" + screw.side;
  return text;
}

}  // namespace mrsns::workflow
