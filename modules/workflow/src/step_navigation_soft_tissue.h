#pragma once
// The soft-tissue part of the navigation step: the session's shape model, spatial and temporal calibrations
// and registration given to the loop's live soft tissue, and what it did written beside the tracking.
#include <filesystem>
#include <string>

#include "mrsns/workflow/navigation.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// The step parameters this part reads.
#define MRSNS_NAVIGATION_SOFT_TISSUE_KEYS \
  "soft_tissue", "soft_tissue_margin_mm", "soft_tissue_sd", "observation_sd_mm", "observation_lifetime_frames", \
      "probe_tool"

/// soft_tissue = "auto" (default: on when the source delivers ultrasound and the session has a shape model,
/// an ImageToProbe calibration and a registration), "on" (the same, an error naming what is missing) or "off".
/// soft_tissue_margin_mm and soft_tissue_sd: the supervisor keeps the drill margin + sd x the posterior's
/// standard deviation away. probe_tool ("Probe"): the tracked probe whose frames navigation uses
/// (<probe_tool>ToTracker); the spatial calibration must have been made with it. Throws InvalidArgumentError for bad values or, with "on", a missing input.
void configureNavigationSoftTissue(const Session& session, const Params& params, NavigationOptions& options);

/// Writes the posterior after every update (`file`, JSON "mrsns-soft-tissue/1": the model, its placement and
/// each update's frame time and coefficients: what a scorer compares with the truth) and returns the step's
/// figures. `file` is not written when the soft tissue was off.
Json navigationSoftTissueFigures(const Session& session, const NavigationOptions& options, const NavigationLoop& loop,
                                 const std::filesystem::path& file);

}  // namespace mrsns::workflow::detail
