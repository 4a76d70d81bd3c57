#pragma once
// The preparation area of paper 001 Fig. 4: data import (CT, meshes,
// landmarks, tracked sequences), registration and calibration (pivot, US
// spatial and temporal, robot, HMD). Buttons only ask; the main window runs.
#include <QWidget>
#include <vector>

#include "step_list.h"

class QLabel;

namespace mrsns::gui {

enum class ImportKind { CtImage, Mesh, Landmarks, Sequence };

class PreparationPanel : public QWidget {
  Q_OBJECT
 public:
  explicit PreparationPanel(QWidget* parent = nullptr);

  /// Creates the step rows for the steps of area "preparation".
  void setSteps(const std::vector<StepEntry>& steps);
  void setSessionText(const QString& name, const QString& folder);
  void setStepState(const QString& step, StepState state, const QString& detail = {});
  void setBusy(bool busy);

 signals:
  void importRequested(mrsns::gui::ImportKind kind);
  void pivotCalibrationRequested();
  void runStepRequested(const QString& step);

 private:
  QLabel* session_label_ = nullptr;
  StepList* data_ = nullptr;
  StepList* planning_ = nullptr;
  StepList* devices_ = nullptr;
  StepList* registration_ = nullptr;
  StepList* calibration_ = nullptr;
  std::vector<QWidget*> import_buttons_;
};

}  // namespace mrsns::gui
