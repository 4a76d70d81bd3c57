#pragma once
// A surgical session: one folder holding session.json and the data files it
// names, by paths relative to the folder so a session can be moved or copied
// as a whole. session.json is a typed document (version 2, see
// session_document.h and modules/workflow/doc/session.md): the patient's CT,
// label maps, models, shape model, fiducials and planned screws, the
// calibrations, registrations and recordings with their provenance, and the
// history of every workflow step (its figures and the files it wrote). The
// state is saved after every change, atomically (a temporary file renamed over
// session.json), so a crash never leaves a half-written state behind.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/workflow/session_document.h"

namespace mrsns::workflow {

/// The session.json layout version this build writes (it reads 1 and 2).
inline constexpr int kSessionVersion = 2;

class Session {
 public:
  /// Makes `folder` (and its parents) and writes a fresh session.json.
  /// Throws FileError when `folder` exists and is not empty, or cannot be made.
  static Session create(const std::filesystem::path& folder);
  /// Reads `folder`/session.json. Throws FileError when it is missing or
  /// unreadable, FormatError when it is not valid JSON, lacks "version" or
  /// "steps", or has a version this build does not know. A version-1 session
  /// is upgraded: its file is kept as session.v1.json beside the new one, every
  /// step record stays, and what the typed document can tell from them is
  /// filled in: the imported CT (its geometry read from the file), meshes and
  /// landmarks and a registration's models and plan marked provenance
  /// "migration"; the calibrations and registrations derived from the step
  /// records as for any session (provenance "step"); the log says so.
  static Session open(const std::filesystem::path& folder);

  [[nodiscard]] const std::filesystem::path& folder() const { return folder_; }
  /// The whole document: {"version":2,"created","modified","images","label_maps","models","shape_models",
  /// "fiducials","plans","calibrations","registrations","recordings","steps":{name:{status,summary,figures,
  /// outputs,params,time,sequence}},"log":[...]}.
  [[nodiscard]] const nlohmann::json& state() const { return state_; }
  /// The version the folder held when it was opened (1 for a migrated session).
  [[nodiscard]] int openedVersion() const { return opened_version_; }

  /// Stores `result` under steps[step] (with the time and order it was
  /// recorded), derives the calibrations, registrations and recordings from
  /// the step records again, and saves.
  void recordStep(const std::string& step, const nlohmann::json& result);
  /// The recorded result of `step`, or null when it has not run.
  [[nodiscard]] nlohmann::json step(const std::string& step) const;
  /// Appends a line to the session log ({"time","level","message"}) and saves.
  void log(const std::string& level, const std::string& message);
  /// Writes session.json atomically (temporary file, fsync, rename).
  void save() const;
  /// folder()/relative; throws InvalidArgumentError for an absolute path or
  /// one that climbs out of the folder ("..").
  [[nodiscard]] std::filesystem::path resolve(const std::string& relative) const;
  /// `file` relative to the folder when it lies inside it, else empty.
  [[nodiscard]] std::string relativeName(const std::filesystem::path& file) const;

  // The typed document. Getters read session.json's state; setters replace
  // the entry and save. Entries name their files relative to the folder.

  [[nodiscard]] std::optional<ImageEntry> ct() const;
  void setCt(const ImageEntry& ct);

  [[nodiscard]] std::vector<LabelMapEntry> labelMaps() const;
  [[nodiscard]] std::optional<LabelMapEntry> labelMap(const std::string& id) const;
  /// Replaces the label map of the same id, or adds it.
  void putLabelMap(const LabelMapEntry& labels);

  [[nodiscard]] std::vector<ModelEntry> models() const;
  [[nodiscard]] std::vector<ModelEntry> models(ModelRole role) const;
  [[nodiscard]] std::optional<ModelEntry> model(const std::string& id) const;
  /// Replaces each model of the same id, or adds it; one save.
  void putModels(const std::vector<ModelEntry>& models);
  void putModel(const ModelEntry& model) { putModels({model}); }
  /// False when there is no model `id`.
  bool removeModel(const std::string& id);
  /// `base`, or `base-2`, `base-3`, ... whichever no model uses yet.
  [[nodiscard]] std::string freeModelId(const std::string& base) const;

  [[nodiscard]] std::optional<ShapeModelEntry> shapeModel() const;
  void setShapeModel(const ShapeModelEntry& model);

  [[nodiscard]] std::optional<FiducialSet> fiducials() const;
  void setFiducials(const FiducialSet& fiducials);

  [[nodiscard]] std::vector<PlannedScrew> plans() const;
  [[nodiscard]] std::optional<PlannedScrew> plan(const std::string& name) const;
  void setPlans(const std::vector<PlannedScrew>& plans);

  /// Moves the CT, label maps, models, shape model, fiducials and plan into
  /// state["set_aside"] (with the time and `reason`) and empties them: what a
  /// new CT replaces is kept in the document, never deleted. Saves.
  void setAsidePatientData(const std::string& reason);

  /// The calibration or registration named `name` ("StylusTipToStylus",
  /// "CTToPatient") from the latest step record that gives it among the
  /// steps whose latest run succeeded. A step run again that failed or was
  /// cancelled gives nothing any more: a failed recalibration puts the tool
  /// in doubt, so its earlier result is not used silently (run it again).
  [[nodiscard]] std::optional<TransformEntry> transform(const std::string& name) const;
  [[nodiscard]] std::vector<TransformEntry> calibrations() const;
  [[nodiscard]] std::vector<TransformEntry> registrations() const;
  [[nodiscard]] std::vector<RecordingEntry> recordings() const;

 private:
  Session(std::filesystem::path folder, nlohmann::json state, int opened_version);
  /// Calibrations, registrations and recordings from the step records.
  void deriveFromSteps();
  void migrateFromVersion1(const std::string& original_text);
  void touchAndSave();
  std::filesystem::path folder_;
  nlohmann::json state_;
  int opened_version_ = kSessionVersion;
};

}  // namespace mrsns::workflow
