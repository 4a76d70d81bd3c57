#include "preparation_panel.h"

#include <QGridLayout>
#include <QGroupBox>
#include <QLabel>
#include <QPushButton>
#include <QVBoxLayout>

namespace mrsns::gui {

PreparationPanel::PreparationPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(6, 6, 6, 6);
  layout->setSpacing(8);

  auto* session = new QGroupBox(tr("Session"), this);
  auto* session_layout = new QVBoxLayout(session);
  session_label_ = new QLabel(tr("no session open"), session);
  session_label_->setObjectName(QStringLiteral("sessionLabel"));
  session_label_->setWordWrap(true);
  session_label_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  session_layout->addWidget(session_label_);
  layout->addWidget(session);

  auto* import = new QGroupBox(tr("Data import"), this);
  auto* grid = new QGridLayout(import);
  const std::tuple<ImportKind, const char*, QString, QString> imports[] = {
      {ImportKind::CtImage, "importCt", tr("CT image…"), tr("NRRD, NIfTI, MetaImage or DICOM")},
      {ImportKind::Mesh, "importMesh", tr("Surface mesh…"), tr("STL, VTP, VTK, OBJ or PLY")},
      {ImportKind::Landmarks, "importLandmarks", tr("Landmarks…"), tr("Slicer markups JSON, FCSV or CSV")},
      {ImportKind::Sequence, "importSequence", tr("Sequence…"), tr("PLUS sequence (.seq.nrrd, .mha)")},
  };
  int i = 0;
  for (const auto& [kind, name, text, tip] : imports) {
    auto* button = new QPushButton(text, import);
    button->setObjectName(QString::fromLatin1(name));
    button->setToolTip(tip);
    grid->addWidget(button, i / 2, i % 2);
    import_buttons_.push_back(button);
    connect(button, &QPushButton::clicked, this, [this, k = kind] { emit importRequested(k); });
    ++i;
  }
  layout->addWidget(import);

  data_ = new StepList(tr("Patient data"), this);
  planning_ = new StepList(tr("Planning"), this);
  devices_ = new StepList(tr("Devices"), this);
  registration_ = new StepList(tr("Registration"), this);
  calibration_ = new StepList(tr("Calibration"), this);
  auto* pivot = new QPushButton(tr("Pivot calibration from a file…"), calibration_);
  pivot->setObjectName(QStringLiteral("pivotCalibration"));
  pivot->setToolTip(tr("Tip offset of a tracked pointer from a PLUS recording or a pose CSV recorded while "
                       "pivoting (Tool pivot calibration acquires it live from the tracker)"));
  calibration_->addWidgetRow(pivot);
  import_buttons_.push_back(pivot);
  connect(pivot, &QPushButton::clicked, this, &PreparationPanel::pivotCalibrationRequested);
  for (auto* list : {data_, planning_, devices_, registration_, calibration_}) {
    layout->addWidget(list);
    connect(list, &StepList::runRequested, this, &PreparationPanel::runStepRequested);
    list->hide();
  }
  layout->addStretch(1);
}

void PreparationPanel::setSteps(const std::vector<StepEntry>& steps) {
  for (const auto& step : steps) {
    if (step.area != QLatin1String("preparation")) continue;
    StepList* list = step.group == QLatin1String("data")           ? data_
                     : step.group == QLatin1String("planning")     ? planning_
                     : step.group == QLatin1String("calibration")  ? calibration_
                     : step.group == QLatin1String("registration") ? registration_
                                                                   : devices_;
    if (list->hasStep(step.name)) continue;
    list->addStep(step);
    list->show();
  }
}

void PreparationPanel::setSessionText(const QString& name, const QString& folder) {
  // The folder name reads at a glance; the full path is in the tooltip and the status bar.
  session_label_->setText(QStringLiteral("<b>%1</b>").arg(name.toHtmlEscaped()));
  session_label_->setToolTip(folder);
}

void PreparationPanel::setStepState(const QString& step, StepState state, const QString& detail) {
  for (auto* list : {data_, planning_, devices_, registration_, calibration_}) list->setStepState(step, state, detail);
}

void PreparationPanel::setBusy(bool busy) {
  for (auto* list : {data_, planning_, devices_, registration_, calibration_}) list->setBusy(busy);
  for (auto* button : import_buttons_) button->setEnabled(!busy);
}

}  // namespace mrsns::gui
