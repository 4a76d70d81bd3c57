// Typed sections of session.json: defaults, what the step records give, and
// the upgrade from version 1 (session_state.h).
#include "session_state.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <set>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/landmarks_io.h"
#include "mrsns/workflow/session_document.h"

namespace mrsns::workflow {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

bool endsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

bool stepSucceeded(const Json& entry) {
  // An import record of a version-1 GUI has no status: it only existed when the import worked.
  return entry.is_object() && entry.value("status", "ok") == "ok";
}

bool stepSimulated(const Json& entry) {
  if (!entry.contains("figures") || !entry["figures"].is_object()) return false;
  const Json& f = entry["figures"];
  return (f.contains("simulated") && f["simulated"].is_boolean() && f["simulated"].get<bool>()) ||
         f.contains("simulation_truth");
}

/// The figures that judge a result, without the large parts (series, per-frame lists, the transforms themselves).
Json qualityFigures(const Json& entry) {
  Json quality = Json::object();
  if (entry.contains("summary") && entry["summary"].is_string()) quality["summary"] = entry["summary"];
  if (!entry.contains("figures") || !entry["figures"].is_object()) return quality;
  for (const auto& [key, value] : entry["figures"].items()) {
    if (value.is_number() || value.is_boolean() || (value.is_string() && value.get_ref<const std::string&>().size() < 200)) {
      quality[key] = value;
    }
  }
  return quality;
}

std::string recordingKind(const std::string& file) {
  const std::string name = lower(fs::path(file).filename().string());
  const bool sequence = endsWith(name, ".mhd") || endsWith(name, ".mha") || endsWith(name, ".seq.nrrd");
  if (name.find("dataset") != std::string::npos && fs::path(file).extension().empty()) return "dataset";
  if (!sequence) return {};
  if (name.find("video") != std::string::npos || name.find("sweep") != std::string::npos ||
      endsWith(name, ".igs.mha")) {
    return "video";
  }
  return "tracking";
}

Provenance stepProvenance(const std::string& step, const Json& entry) {
  Provenance p;
  p.source = "step";
  p.step = step;
  p.time = entry.value("time", "");
  p.simulated = stepSimulated(entry);
  return p;
}

// The version-1 GUI guessed a mesh's role from its file name; the migration keeps that guess and says so.
ModelRole guessedRole(const std::string& lower_name) {
  for (const char* word : {"vessel", "artery", "carotid", "vein", "aorta"}) {
    if (lower_name.find(word) != std::string::npos) return ModelRole::Vessel;
  }
  for (const char* word : {"tissue", "soft", "skin", "muscle", "posterior", "shape"}) {
    if (lower_name.find(word) != std::string::npos) return ModelRole::SoftTissue;
  }
  return ModelRole::Bone;
}

Json stringsOf(const Json& entry, const char* key) {
  return entry.is_object() && entry.contains(key) && entry[key].is_array() ? entry[key] : Json::array();
}

std::string uniqueId(const Json& models, const std::string& base) {
  for (int n = 1;; ++n) {
    const std::string id = n == 1 ? base : base + "-" + std::to_string(n);
    const bool used = std::any_of(models.begin(), models.end(), [&](const Json& m) { return m.value("id", "") == id; });
    if (!used) return id;
  }
}

Eigen::Vector3d vec3(const Json& j) {
  return {j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>()};
}

}  // namespace

void addTypedSections(Json& state) {
  for (const char* list : {"images", "label_maps", "models", "shape_models", "plans", "recordings"}) {
    if (!state.contains(list) || !state[list].is_array()) state[list] = Json::array();
  }
  for (const char* map : {"calibrations", "registrations"}) {
    if (!state.contains(map) || !state[map].is_object()) state[map] = Json::object();
  }
  if (!state.contains("fiducials")) state["fiducials"] = nullptr;
}

void deriveStepProducts(Json& state) {
  struct Candidate {
    std::int64_t sequence = 0;
    std::string step;
    TransformEntry entry;
  };
  std::map<std::string, Candidate> latest;
  struct Recorded {
    std::int64_t sequence = 0;
    RecordingEntry entry;
  };
  std::vector<Recorded> recordings;
  // The patient's images are data, not recordings, whatever their extension (a CT kept as .mha).
  std::set<std::string> patient_files;
  for (const char* key : {"images", "label_maps"}) {
    if (!state.contains(key) || !state[key].is_array()) continue;
    for (const auto& e : state[key]) {
      if (e.is_object() && e.contains("file") && e["file"].is_string()) patient_files.insert(e["file"].get<std::string>());
    }
  }
  const auto consider = [&](const std::string& step, const Json& entry) {
    if (!entry.is_object()) return;
    const std::int64_t sequence = entry.value("sequence", std::int64_t{0});
    const Json outputs = stringsOf(entry, "outputs");
    for (const auto& output : outputs) {
      if (!output.is_string() || patient_files.count(output.get<std::string>()) > 0) continue;
      const std::string kind = recordingKind(output.get<std::string>());
      if (kind.empty()) continue;
      Recorded r;
      r.sequence = sequence;
      r.entry.file = output.get<std::string>();
      r.entry.kind = kind;
      r.entry.provenance = stepProvenance(step, entry);
      recordings.push_back(std::move(r));
    }
    if (!stepSucceeded(entry) || !entry.contains("figures") || !entry["figures"].is_object()) return;
    const Json& figures = entry["figures"];
    if (!figures.contains("transforms") || !figures["transforms"].is_object()) return;
    for (const auto& [name, matrix] : figures["transforms"].items()) {
      if (!matrix.is_array() || matrix.size() != 16) continue;
      auto it = latest.find(name);
      // Ties (version-1 records have no sequence): the later time, then the step name, so the result is stable.
      const std::string time = entry.value("time", "");
      if (it != latest.end()) {
        const auto& c = it->second;
        const bool newer = sequence != c.sequence ? sequence > c.sequence
                           : time != c.entry.provenance.time ? time > c.entry.provenance.time
                                                             : step > c.step;
        if (!newer) continue;
      }
      Candidate c;
      c.sequence = sequence;
      c.step = step;
      c.entry.name = name;
      c.entry.kind = transformKind(name);
      for (int i = 0; i < 16; ++i) {
        const Json& x = matrix[static_cast<std::size_t>(i)];
        c.entry.matrix(i / 4, i % 4) = x.is_number() ? x.get<double>() : 0.0;
      }
      for (const auto& output : outputs) {
        if (output.is_string() && fs::path(output.get<std::string>()).stem().string() == name) {
          c.entry.file = output.get<std::string>();
        }
      }
      c.entry.provenance = stepProvenance(step, entry);
      c.entry.provenance.quality = qualityFigures(entry);
      latest[name] = std::move(c);
    }
  };
  for (const auto& [step, entry] : state.at("steps").items()) {
    consider(step, entry);
  }
  Json calibrations = Json::object();
  Json registrations = Json::object();
  for (const auto& [name, c] : latest) {
    (c.entry.kind == "registration" ? registrations : calibrations)[name] = c.entry;
  }
  state["calibrations"] = std::move(calibrations);
  state["registrations"] = std::move(registrations);
  std::stable_sort(recordings.begin(), recordings.end(),
                   [](const Recorded& a, const Recorded& b) { return a.sequence < b.sequence; });
  // One entry per file (a step run again names its files again).
  Json list = Json::array();
  std::set<std::string> listed;
  for (auto r = recordings.rbegin(); r != recordings.rend(); ++r) {
    if (listed.insert(r->entry.file).second) list.insert(list.begin(), r->entry);
  }
  state["recordings"] = std::move(list);
}

void migrateVersion1Content(Json& state, const fs::path& folder) {
  const Json& steps = state.at("steps");
  const auto exists = [&folder](const std::string& relative) {
    std::error_code ec;
    return !relative.empty() && fs::path(relative).is_relative() && fs::is_regular_file(folder / relative, ec);
  };
  const auto migrated = [](const std::string& step, const Json& entry) {
    Provenance p;
    p.source = "migration";
    p.step = step;
    p.time = entry.value("time", "");
    p.simulated = stepSimulated(entry);
    return p;
  };
  // The CT the version-1 GUI imported (a copy in imported/).
  if (steps.contains("import-ct")) {
    const Json& entry = steps["import-ct"];
    const Json outputs = stringsOf(entry, "outputs");
    if (!outputs.empty() && outputs.back().is_string() && exists(outputs.back().get<std::string>())) {
      ImageEntry ct;
      ct.file = outputs.back().get<std::string>();
      ct.name = fs::path(ct.file).filename().string();
      const Json& f = entry.contains("figures") ? entry["figures"] : Json::object();
      ct.format = f.value("format", "");
      if (f.contains("size_px") && f["size_px"].is_array() && f["size_px"].size() == 3) {
        for (int a = 0; a < 3; ++a) ct.size_px[static_cast<std::size_t>(a)] = f["size_px"][static_cast<std::size_t>(a)].get<int>();
      }
      if (f.contains("spacing_mm") && f["spacing_mm"].is_array() && f["spacing_mm"].size() == 3) {
        ct.spacing_mm = vec3(f["spacing_mm"]);
      }
      ct.provenance = migrated("import-ct", entry);
      // A version-1 record holds the size and spacing only: the CT's whole geometry from the file itself, so the
      // checks that a model, fiducial or screw lies inside the CT use the CT's true box.
      try {
        const auto read = io::readImageFile(folder / ct.file);
        const ImageVolume& image = read.image;
        ct.size_px = image.size;
        ct.spacing_mm = image.spacing;
        ct.origin_mm = image.origin;
        ct.direction = image.direction;
        ct.pixel_type = pixelTypeName(image.pixel_type);
        ct.format = io::imageFormatName(read.format);
        ct.modality = read.modality;
      } catch (const mrsns::Error& e) {
        ct.provenance.quality["geometry"] = std::string("only the size and spacing of the version-1 record: ") + e.what();
      }
      state["images"].push_back(ct);
    }
  }
  Json& models = state["models"];
  const auto addModel = [&](const std::string& file, ModelRole role, const std::string& step, const Json& entry,
                            const std::string& note) {
    if (!exists(file)) return;
    ModelEntry m;
    m.name = fs::path(file).stem().string();
    m.id = uniqueId(models, m.name);
    m.file = file;
    m.role = role;
    m.color = roleColor(role);
    m.opacity = role == ModelRole::SoftTissue ? 0.25 : 1.0;
    m.provenance = migrated(step, entry);
    m.provenance.quality = Json{{"note", note}};
    models.push_back(m);
  };
  if (steps.contains("import-mesh")) {
    for (const auto& output : stringsOf(steps["import-mesh"], "outputs")) {
      if (!output.is_string()) continue;
      const std::string file = output.get<std::string>();
      addModel(file, guessedRole(lower(fs::path(file).filename().string())), "import-mesh", steps["import-mesh"],
               "role guessed from the file name when the session was upgraded from version 1");
    }
  }
  // A version-1 registration generated the phantom's CT itself and wrote its models and plan.
  if (steps.contains("registration") && stepSucceeded(steps["registration"])) {
    const Json& entry = steps["registration"];
    const Json& f = entry.contains("figures") ? entry["figures"] : Json::object();
    for (const auto& m : stringsOf(f, "models")) {
      if (!m.is_object() || !m.contains("file") || !m["file"].is_string()) continue;
      const std::string file = m["file"].get<std::string>();
      const std::string layer = m.value("layer", "");
      const ModelRole role = layer == "vertebrae" ? ModelRole::Bone : guessedRole(lower(file));
      addModel(file, role, "registration", entry, "written by a version-1 registration (the generated phantom)");
    }
    for (const auto& p : stringsOf(f, "paths")) {
      if (!p.is_object() || !p.contains("entry_ct") || !p.contains("target_ct")) continue;
      PlannedScrew screw;
      screw.name = p.value("name", "");
      screw.vertebra = screw.name.substr(0, screw.name.find(' '));
      if (screw.name.find("left") != std::string::npos) screw.side = "left";
      if (screw.name.find("right") != std::string::npos) screw.side = "right";
      screw.entry = vec3(p["entry_ct"]);
      screw.target = vec3(p["target_ct"]);
      screw.provenance = migrated("registration", entry);
      state["plans"].push_back(screw);
    }
  }
  if (steps.contains("import-landmarks")) {
    const Json& entry = steps["import-landmarks"];
    const Json outputs = stringsOf(entry, "outputs");
    if (!outputs.empty() && outputs.back().is_string() && exists(outputs.back().get<std::string>())) {
      try {
        const auto landmarks = io::readLandmarks(folder / outputs.back().get<std::string>());
        FiducialSet set;
        set.file = outputs.back().get<std::string>();
        for (const auto& l : landmarks.points) {
          FiducialPoint point;
          point.label = l.label;
          point.position_ct = l.position;
          point.source = "file";
          set.points.push_back(point);
        }
        set.provenance = migrated("import-landmarks", entry);
        state["fiducials"] = set;
      } catch (const mrsns::Error& e) {
        logger()->warn("session upgrade: the imported landmarks '{}' could not be read ({}); they are not listed as "
                       "fiducials", outputs.back().get<std::string>(), e.what());
      }
    }
  }
}

}  // namespace mrsns::workflow
