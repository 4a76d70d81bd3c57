#pragma once
// The module trials the workflow steps run beside their own transform chains:
// paper 001 Fig. 7 (hmd::runCubeTrial), paper 000's checkerboard protocol
// (hmd::runCheckerboardTrial) and paper 001's placement trial
// (robot::runPlacementTrial). Each returns its figures with the noise model
// that produced them and the paper's numbers beside them.
#include <cstdint>

#include "step_internal.h"

namespace mrsns::workflow::detail {

Json cubeTrialFigures(int trials, std::uint64_t seed);
Json checkerboardTrialFigures(int poses, std::uint64_t seed);
Json placementTrialFigures(int trials, std::uint64_t seed);

}  // namespace mrsns::workflow::detail
