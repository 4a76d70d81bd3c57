#pragma once
// The dialogs that gather a preparation step's parameters from the user:
// which DICOM series, how to place a label map on the CT, which labels to
// mesh. Each returns the step's parameters, or nothing when cancelled.
#include <QString>
#include <nlohmann/json.hpp>
#include <optional>

class QWidget;

namespace mrsns::workflow {
class Session;
}

namespace mrsns::gui {

/// import-ct on a DICOM folder: the series chosen from those listed when the
/// folder holds more than one. Throws mrsns::Error when the folder cannot be scanned.
std::optional<nlohmann::json> askDicomSeries(QWidget* parent, const QString& folder);

/// import-label-map: the file, its label scheme, and, when the session has
/// label maps, one to align it to; resample onto the CT's grid.
std::optional<nlohmann::json> askLabelMapImport(QWidget* parent, const workflow::Session& session);

/// make-models: from a label map's labels (checked in a list, with their
/// roles) or from a bone threshold, and the headset copy's size.
std::optional<nlohmann::json> askMakeModels(QWidget* parent, const workflow::Session& session);

/// import-model: the mesh's role (bone, vessel, soft tissue, neural, fiducial,
/// other), offered as the one its file name suggests; the parameters for the
/// step with `path`.
std::optional<nlohmann::json> askModelImport(QWidget* parent, const QString& path);

}  // namespace mrsns::gui
