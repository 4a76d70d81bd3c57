#pragma once
// What session.cpp does to the raw session.json state besides reading and
// writing it: the typed sections a state must have, the calibrations,
// registrations and recordings derived from the step records, and the
// upgrade of a version-1 state (session_state.cpp).
#include <filesystem>
#include <nlohmann/json.hpp>

namespace mrsns::workflow {

/// Adds every typed section of version 2 that `state` lacks (empty).
void addTypedSections(nlohmann::json& state);

/// Recomputes state.calibrations, state.registrations and state.recordings
/// from state.steps: for each transform name the latest (by record order)
/// successful step that gave it in figures.transforms; every recording any
/// step wrote (a failed or cancelled step keeps its recordings).
void deriveStepProducts(nlohmann::json& state);

/// Fills the typed sections of a version-1 state from its step records (the
/// GUI's imports, a registration's models and plan), each marked with
/// provenance "migration". `folder` is the session folder (files are checked
/// to exist there).
void migrateVersion1Content(nlohmann::json& state, const std::filesystem::path& folder);

}  // namespace mrsns::workflow
