#pragma once
// The planning area: the CT's window/level, the planned pedicle screws with
// their live figures (cortical breach, clearance to vessels, nerves and soft
// tissue, angles to the vertebra's axes), the selected screw's fields, the
// trajectory view, and the fiducials. It shows and asks; the main window
// changes the session.
#include <QWidget>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "mrsns/workflow/session_document.h"

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QLineEdit;
class QPushButton;
class QTableWidget;

namespace mrsns::gui {

class PlanningPanel : public QWidget {
  Q_OBJECT
 public:
  explicit PlanningPanel(QWidget* parent = nullptr);

  /// The plan and fiducials to list; keeps the selection by name when it can.
  void setPlan(const std::vector<workflow::PlannedScrew>& plans);
  void setFiducials(const std::vector<workflow::FiducialPoint>& fiducials);
  /// Updates one screw's row and, when it is the selected one, its fields and figures (while it is dragged).
  void updateScrew(const workflow::PlannedScrew& screw);
  /// The selected screw's name, empty when none.
  [[nodiscard]] QString selectedScrew() const;
  void selectScrew(const QString& name);
  /// The diameter and length a new screw gets.
  [[nodiscard]] double newDiameter() const;
  [[nodiscard]] double newLength() const;
  /// What the status line under the buttons says (placing a screw: "click its entry").
  void setHint(const QString& text);
  void setWindowLevel(double window, double level);
  [[nodiscard]] bool trajectoryShown() const;
  void setBusy(bool busy);

 signals:
  void windowLevelChanged(double window, double level);
  void screwSelected(const QString& name);
  /// The fields of the selected screw were edited (name, vertebra, side, diameter, length).
  void screwEdited(const QString& name, const QString& new_name, const QString& vertebra, const QString& side,
                   double diameter_mm, double length_mm);
  void newScrewRequested();
  void deleteScrewRequested(const QString& name);
  void importPlanRequested();
  void exportPlanRequested();
  void trajectoryToggled(bool shown);
  void placeFiducialRequested();
  void deleteFiducialRequested(const QString& label);
  void findFiducialsRequested();

 private:
  void fillFields(const workflow::PlannedScrew& screw);
  void emitEdit();
  /// Row `row` of the screw table shows `screw` (its cells' texts, created when missing).
  void fillRow(int row, const workflow::PlannedScrew& screw);
  static QString figuresText(const nlohmann::json& figures);

  std::vector<workflow::PlannedScrew> plans_;
  QComboBox* presets_ = nullptr;
  QDoubleSpinBox* window_ = nullptr;
  QDoubleSpinBox* level_ = nullptr;
  QTableWidget* screws_ = nullptr;
  QLineEdit* name_ = nullptr;
  QLineEdit* vertebra_ = nullptr;
  QComboBox* side_ = nullptr;
  QDoubleSpinBox* diameter_ = nullptr;
  QDoubleSpinBox* length_ = nullptr;
  QLabel* figures_ = nullptr;
  QLabel* hint_ = nullptr;
  QCheckBox* trajectory_ = nullptr;
  QTableWidget* fiducials_ = nullptr;
  std::vector<QPushButton*> buttons_;
  bool filling_ = false;
};

}  // namespace mrsns::gui
