#pragma once
// Screw planning on the session's anatomy: the session's models loaded once
// (bone surfaces with each vertebra's anatomical frame, and the structures a
// screw must keep away from), then any planned screw evaluated against them
// in a few milliseconds, so the GUI can recompute a screw's figures while its
// end is dragged. The figures are registration::evaluateScrewPlan's, as JSON
// (the form session.json and `session info --json` carry).
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mrsns/workflow/session.h"

namespace mrsns::workflow {

class PlanningAnatomyCache {
 public:
  /// Reads every model of the session: bone models become the vertebrae
  /// (a frame for each one named after a vertebra, its superior axis from
  /// its neighbours' centroids when the session has them), vessel, neural,
  /// soft-tissue and other models the structures to avoid; fiducial models
  /// are left out. Throws FileError when a model's file is missing.
  explicit PlanningAnatomyCache(const Session& session);
  ~PlanningAnatomyCache();
  PlanningAnatomyCache(const PlanningAnatomyCache&) = delete;
  PlanningAnatomyCache& operator=(const PlanningAnatomyCache&) = delete;

  /// The screw's figures: {vertebra, vertebra_from, angles, breach,
  /// clearance: {vessel, soft_tissue, neural, other}, structures, warnings};
  /// a part is null when the anatomy lacks what it needs (no vertebra, no
  /// vessel model), never a made-up number. Throws InvalidArgumentError for
  /// an unusable screw (entry == target, non-positive diameter).
  [[nodiscard]] nlohmann::json evaluate(const PlannedScrew& screw) const;

  /// Names of the vertebrae and of the structures to avoid, as loaded.
  [[nodiscard]] std::vector<std::string> vertebrae() const;
  [[nodiscard]] std::vector<std::string> structures() const;
  /// Problems met while loading (an open mesh that cannot be a bone, a
  /// vertebra whose frame is ambiguous), for the user.
  [[nodiscard]] const std::vector<std::string>& warnings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Adds `screw`, or replaces the screw named `replaces` (its own name when
/// empty), after checking it against the session's CT (two distinct ends
/// inside the image, a diameter in (0, 15] mm, a length in [0, 200] mm, side
/// left or right); its figures from `anatomy`, its vertebra and side from
/// them when the screw names none; the plan's markups copy
/// (plans/Plan.mrk.json) rewritten; saves. Returns the screw as stored.
/// Throws InvalidArgumentError naming what is wrong (the session keeps its
/// plan unchanged then).
PlannedScrew savePlannedScrew(Session& session, PlannedScrew screw, const PlanningAnatomyCache& anatomy,
                              const std::string& replaces = {});

/// A name for a new screw: "<vertebra> <side>" ("L2 left") from its figures
/// when it lies in a named vertebra and no screw of `plans` has that name,
/// else the first free "Screw N". The GUI and plan-screw without name= use it.
std::string nameForNewScrew(const std::vector<PlannedScrew>& plans, const nlohmann::json& figures);

/// Removes the screw `name` and rewrites the plan's markups copy; false when there is none.
bool removePlannedScrew(Session& session, const std::string& name);

/// The screw as a Slicer markups line description ("vertebra=L1; side=left;
/// diameter_mm=6.5; length_mm=45").
std::string plannedScrewDescription(const PlannedScrew& screw);

}  // namespace mrsns::workflow
