#include "step_list.h"

#include <QGridLayout>
#include <QLabel>
#include <QPushButton>
#include <QStyle>
#include <QVariant>
#include <algorithm>

#include "output_panel.h"

namespace mrsns::gui {

StepList::StepList(const QString& title, QWidget* parent) : QGroupBox(title, parent) {
  auto* grid = new QGridLayout(this);
  grid->setColumnStretch(1, 1);
  grid->setVerticalSpacing(4);
}

QPushButton* StepList::addStep(const StepEntry& step) {
  auto* grid = static_cast<QGridLayout*>(layout());
  const int row = next_row_++;
  auto* button = new QPushButton(step.title, this);
  button->setObjectName(QStringLiteral("step_") + step.name);
  button->setToolTip(step.description.isEmpty() ? tr("Run the step \"%1\" on the open session").arg(step.name)
                                                : step.description);
  // The step's name is what the user looks for: the button keeps its whole title, and the status beside it
  // wraps in the room that is left (a long figure, "(simulated)").
  button->setMinimumWidth(std::max(150, button->sizeHint().width()));
  auto* status = new QLabel(tr("not run"), this);
  status->setWordWrap(true);
  status->setObjectName(QStringLiteral("status_") + step.name);
  status->setProperty("stepState", QStringLiteral("none"));
  grid->addWidget(button, row, 0);
  grid->addWidget(status, row, 1);
  rows_[step.name] = Row{button, status};
  connect(button, &QPushButton::clicked, this, [this, name = step.name] { emit runRequested(name); });
  return button;
}

void StepList::addWidgetRow(QWidget* widget) {
  auto* grid = static_cast<QGridLayout*>(layout());
  grid->removeWidget(widget);
  grid->addWidget(widget, next_row_++, 0, 1, 2);
}

void StepList::setStepState(const QString& name, StepState state, const QString& detail) {
  const auto it = rows_.find(name);
  if (it == rows_.end()) return;
  QLabel* label = it->second.status;
  QString text, property;
  switch (state) {
    case StepState::NotRun: text = tr("not run"), property = QStringLiteral("none"); break;
    case StepState::Running: text = tr("running…"), property = QStringLiteral("running"); break;
    case StepState::Done: text = tr("✓ done"), property = QStringLiteral("done"); break;
    case StepState::Failed: text = tr("✗ failed"), property = QStringLiteral("failed"); break;
    case StepState::Cancelled: text = tr("cancelled"), property = QStringLiteral("failed"); break;
  }
  if (!detail.isEmpty()) {
    // Narrow rows: a done step shows its figure instead of the word.
    text = state == StepState::Done ? QStringLiteral("✓ ") + detail : text + QStringLiteral("  ") + detail;
  }
  label->setText(text);
  label->setToolTip(detail);
  label->setProperty("stepState", property);
  label->style()->unpolish(label);
  label->style()->polish(label);
}

void StepList::setBusy(bool busy) {
  for (auto& [name, row] : rows_) row.button->setEnabled(!busy);
}

/// The headline figure shown next to a step's button.
namespace {

const nlohmann::json* findLeaf(const nlohmann::json& figures, const char* needle, int depth, std::string* key) {
  for (auto it = figures.begin(); it != figures.end(); ++it) {
    const std::string& k = it.key();
    if (k.find("expected") != std::string::npos || k.find("paper") != std::string::npos ||
        k.find("noise") != std::string::npos || k.find("predicted") != std::string::npos ||
        k.find("truth") != std::string::npos) {
      continue;
    }
    if (it->is_number() && k.find(needle) != std::string::npos) return *key = k, &*it;
    if (it->is_object() && depth > 0) {
      if (const auto* leaf = findLeaf(*it, needle, depth - 1, key)) return leaf;
    }
  }
  return nullptr;
}

// The step's headline figure, or empty.
QString figureHeadline(const nlohmann::json& figures) {
  std::string key;
  // A validation figure, when the step has one, is the one that judges it
  // (the US calibration: the held-out sequence, not the fitted one).
  const auto validation = figures.find("validation");
  const bool has_validation = validation != figures.end() && validation->is_object();
  for (const char* needle : {"fre", "reprojection_3d_mean", "lag", "rms", "error", "offset"}) {
    if (has_validation) {
      if (const auto* leaf = findLeaf(*validation, needle, 0, &key)) return formatFigure(key, *leaf);
    }
    if (const auto* leaf = findLeaf(figures, needle, 1, &key)) {
      return formatFigure(key, *leaf);  // the value only: the row is narrow
    }
  }
  return {};
}

}  // namespace

QString stepHeadline(const nlohmann::json& figures) {
  if (!figures.is_object()) return {};
  const QString figure = figureHeadline(figures);
  // A result from a simulated device says so wherever it is shown.
  const auto simulated = figures.find("simulated");
  if (simulated != figures.end() && simulated->is_boolean() && simulated->get<bool>()) {
    return figure.isEmpty() ? QStringLiteral("simulated") : figure + QStringLiteral(" (simulated)");
  }
  return figure;
}

}  // namespace mrsns::gui
