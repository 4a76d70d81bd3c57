#include "planning_panel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QResizeEvent>
#include <QSignalBlocker>
#include <QTableWidget>
#include <QVBoxLayout>
#include <cmath>

#include "mrsns/rendering/slice_views.h"

namespace mrsns::gui {

namespace {

/// A word-wrapped label that keeps the height its text needs at its width: in a scrolling panel a plain
/// word-wrapped QLabel is squeezed to a line or two (the scroll area sizes its content by minimum size hints,
/// which for wrapped text ignore the width), hiding the figures below.
class WrappingLabel : public QLabel {
 public:
  using QLabel::QLabel;
  [[nodiscard]] QSize minimumSizeHint() const override {
    QSize size = QLabel::minimumSizeHint();
    if (width() > 0) size.setHeight(heightForWidth(width()));
    return size;
  }

 protected:
  void resizeEvent(QResizeEvent* event) override {
    QLabel::resizeEvent(event);
    if (event->size().width() != event->oldSize().width()) updateGeometry();
  }
};

QString number(const nlohmann::json& j, const char* key, int decimals = 1) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return QStringLiteral("—");
  return QString::number(j[key].get<double>(), 'f', decimals);
}

/// "3.2 (aorta)" for the closest structure of a kind, "—" when the session has none.
QString clearanceText(const nlohmann::json& figures, const char* kind) {
  if (!figures.contains("clearance") || !figures["clearance"].is_object()) return QStringLiteral("—");
  const auto& c = figures["clearance"];
  if (!c.contains(kind) || !c[kind].is_object()) return QStringLiteral("—");
  return QStringLiteral("%1 (%2)").arg(number(c[kind], "min_clearance_mm"),
                                       QString::fromStdString(c[kind].value("name", "")));
}

QTableWidgetItem* item(const QString& text) {
  auto* i = new QTableWidgetItem(text);
  i->setFlags(i->flags() & ~Qt::ItemIsEditable);
  return i;
}

}  // namespace

PlanningPanel::PlanningPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(6, 6, 6, 6);

  auto* view = new QGroupBox(tr("CT window"), this);
  auto* view_layout = new QHBoxLayout(view);
  presets_ = new QComboBox(view);
  presets_->setObjectName(QStringLiteral("windowPreset"));
  for (const auto& p : rendering::ctWindowLevelPresets()) {
    presets_->addItem(QString::fromStdString(p.name), QVariantList{p.window, p.level});
  }
  presets_->setCurrentIndex(1);  // soft tissue: what setVolume starts with
  window_ = new QDoubleSpinBox(view);
  window_->setObjectName(QStringLiteral("windowWidth"));
  window_->setRange(1.0, 8000.0);
  window_->setValue(400.0);
  window_->setPrefix(tr("W "));
  level_ = new QDoubleSpinBox(view);
  level_->setObjectName(QStringLiteral("windowLevel"));
  level_->setRange(-2000.0, 4000.0);
  level_->setValue(40.0);
  level_->setPrefix(tr("L "));
  view_layout->addWidget(presets_);
  view_layout->addWidget(window_);
  view_layout->addWidget(level_);
  layout->addWidget(view);
  connect(presets_, qOverload<int>(&QComboBox::activated), this, [this](int index) {
    const auto wl = presets_->itemData(index).toList();
    setWindowLevel(wl[0].toDouble(), wl[1].toDouble());
    emit windowLevelChanged(wl[0].toDouble(), wl[1].toDouble());
  });
  for (auto* spin : {window_, level_}) {
    connect(spin, qOverload<double>(&QDoubleSpinBox::valueChanged), this, [this](double) {
      if (!filling_) emit windowLevelChanged(window_->value(), level_->value());
    });
  }

  auto* plan = new QGroupBox(tr("Planned screws"), this);
  auto* plan_layout = new QVBoxLayout(plan);
  screws_ = new QTableWidget(0, 7, plan);
  screws_->setObjectName(QStringLiteral("screwTable"));
  screws_->setHorizontalHeaderLabels(
      {tr("Screw"), tr("Level"), tr("Breach mm"), tr("Vessel mm"), tr("Nerve mm"), tr("Medial°"), tr("Cranial°")});
  screws_->setSelectionBehavior(QAbstractItemView::SelectRows);
  screws_->setSelectionMode(QAbstractItemView::SingleSelection);
  screws_->verticalHeader()->hide();
  screws_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  screws_->setMinimumHeight(120);
  plan_layout->addWidget(screws_);
  connect(screws_, &QTableWidget::itemSelectionChanged, this, [this] {
    if (filling_) return;
    const QString name = selectedScrew();
    for (const auto& s : plans_) {
      if (QString::fromStdString(s.name) == name) fillFields(s);
    }
    emit screwSelected(name);
  });

  auto* buttons = new QGridLayout;
  const auto button = [&](const char* name, const QString& text, const QString& tip, int row, int col) {
    auto* b = new QPushButton(text, plan);
    b->setObjectName(QString::fromLatin1(name));
    b->setToolTip(tip);
    buttons->addWidget(b, row, col);
    buttons_.push_back(b);
    return b;
  };
  connect(button("newScrew", tr("New screw"), tr("Click its entry, then its target, on a slice or the 3D bone"), 0, 0),
          &QPushButton::clicked, this, &PlanningPanel::newScrewRequested);
  connect(button("deleteScrew", tr("Delete"), tr("Remove the selected screw from the plan"), 0, 1),
          &QPushButton::clicked, this, [this] {
            if (!selectedScrew().isEmpty()) emit deleteScrewRequested(selectedScrew());
          });
  connect(button("importPlan", tr("Import plan…"), tr("Screws from a 3D Slicer markups file of lines"), 1, 0),
          &QPushButton::clicked, this, &PlanningPanel::importPlanRequested);
  connect(button("exportPlan", tr("Export plan…"), tr("The plan as a 3D Slicer markups file of lines"), 1, 1),
          &QPushButton::clicked, this, &PlanningPanel::exportPlanRequested);
  plan_layout->addLayout(buttons);

  auto* form = new QFormLayout;
  name_ = new QLineEdit(plan);
  name_->setObjectName(QStringLiteral("screwName"));
  vertebra_ = new QLineEdit(plan);
  vertebra_->setObjectName(QStringLiteral("screwVertebra"));
  side_ = new QComboBox(plan);
  side_->setObjectName(QStringLiteral("screwSide"));
  side_->addItems({QString(), QStringLiteral("left"), QStringLiteral("right")});
  diameter_ = new QDoubleSpinBox(plan);
  diameter_->setObjectName(QStringLiteral("screwDiameter"));
  diameter_->setRange(1.0, 15.0);
  diameter_->setSingleStep(0.5);
  diameter_->setValue(4.5);
  diameter_->setSuffix(tr(" mm"));
  length_ = new QDoubleSpinBox(plan);
  length_->setObjectName(QStringLiteral("screwLength"));
  length_->setRange(0.0, 200.0);
  length_->setSingleStep(5.0);
  length_->setValue(40.0);
  length_->setSuffix(tr(" mm"));
  length_->setSpecialValueText(tr("entry to target"));
  form->addRow(tr("Name"), name_);
  form->addRow(tr("Vertebra"), vertebra_);
  form->addRow(tr("Side"), side_);
  form->addRow(tr("Diameter"), diameter_);
  form->addRow(tr("Length"), length_);
  plan_layout->addLayout(form);
  connect(name_, &QLineEdit::editingFinished, this, &PlanningPanel::emitEdit);
  connect(vertebra_, &QLineEdit::editingFinished, this, &PlanningPanel::emitEdit);
  connect(side_, qOverload<int>(&QComboBox::activated), this, [this](int) { emitEdit(); });
  connect(diameter_, &QDoubleSpinBox::editingFinished, this, &PlanningPanel::emitEdit);
  connect(length_, &QDoubleSpinBox::editingFinished, this, &PlanningPanel::emitEdit);
  figures_ = new WrappingLabel(tr("no screw selected"), plan);
  figures_->setObjectName(QStringLiteral("screwFigures"));
  figures_->setWordWrap(true);
  figures_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  plan_layout->addWidget(figures_);
  trajectory_ = new QCheckBox(tr("Trajectory view along the selected screw"), plan);
  trajectory_->setObjectName(QStringLiteral("showTrajectory"));
  plan_layout->addWidget(trajectory_);
  connect(trajectory_, &QCheckBox::toggled, this, &PlanningPanel::trajectoryToggled);
  hint_ = new WrappingLabel(plan);
  hint_->setObjectName(QStringLiteral("planningHint"));
  hint_->setWordWrap(true);
  plan_layout->addWidget(hint_);
  layout->addWidget(plan);

  auto* fiducials = new QGroupBox(tr("Fiducials (CT)"), this);
  auto* fid_layout = new QVBoxLayout(fiducials);
  fiducials_ = new QTableWidget(0, 3, fiducials);
  fiducials_->setObjectName(QStringLiteral("fiducialTable"));
  fiducials_->setHorizontalHeaderLabels({tr("Label"), tr("Position (LPS mm)"), tr("From")});
  fiducials_->setSelectionBehavior(QAbstractItemView::SelectRows);
  fiducials_->setSelectionMode(QAbstractItemView::SingleSelection);
  fiducials_->verticalHeader()->hide();
  fiducials_->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  fiducials_->setMinimumHeight(100);
  fid_layout->addWidget(fiducials_);
  auto* fid_buttons = new QHBoxLayout;
  const auto fid_button = [&](const char* name, const QString& text, const QString& tip) {
    auto* b = new QPushButton(text, fiducials);
    b->setObjectName(QString::fromLatin1(name));
    b->setToolTip(tip);
    fid_buttons->addWidget(b);
    buttons_.push_back(b);
    return b;
  };
  connect(fid_button("placeFiducial", tr("At crosshair"), tr("Place a fiducial where the slice views' crosshair is")),
          &QPushButton::clicked, this, &PlanningPanel::placeFiducialRequested);
  connect(fid_button("deleteFiducial", tr("Delete"), tr("Remove the selected fiducial")), &QPushButton::clicked, this,
          [this] {
            const auto rows = fiducials_->selectionModel()->selectedRows();
            if (!rows.empty()) emit deleteFiducialRequested(fiducials_->item(rows.front().row(), 0)->text());
          });
  connect(fid_button("findFiducials", tr("Find in CT"), tr("The fiducial screws: a fiducial label, or metal in the CT")),
          &QPushButton::clicked, this, &PlanningPanel::findFiducialsRequested);
  fid_layout->addLayout(fid_buttons);
  layout->addWidget(fiducials);
  layout->addStretch(1);
}

void PlanningPanel::fillRow(int row, const workflow::PlannedScrew& s) {
  const auto& f = s.figures;
  const QString breach = f.contains("breach") && f["breach"].is_object()
                             ? QStringLiteral("%1 %2").arg(number(f["breach"], "max_breach_mm"),
                                                           QString::fromStdString(f["breach"].value("grade", "")))
                             : QStringLiteral("—");
  const auto& a = f.contains("angles") ? f["angles"] : nlohmann::json();
  const QString cells[] = {QString::fromStdString(s.name), QString::fromStdString(s.vertebra), breach,
                           clearanceText(f, "vessel"),    clearanceText(f, "neural"),       number(a, "medial_deg"),
                           number(a, "cranial_deg")};
  for (int column = 0; column < 7; ++column) {
    // Existing cells change their text only: a drag updates its row many times a second.
    if (auto* cell = screws_->item(row, column)) {
      if (cell->text() != cells[column]) cell->setText(cells[column]);
    } else {
      screws_->setItem(row, column, item(cells[column]));
    }
  }
}

void PlanningPanel::setPlan(const std::vector<workflow::PlannedScrew>& plans) {
  const QString selected = selectedScrew();
  plans_ = plans;
  filling_ = true;
  screws_->setRowCount(static_cast<int>(plans.size()));
  int row_of_selected = -1;
  for (std::size_t i = 0; i < plans.size(); ++i) {
    fillRow(static_cast<int>(i), plans[i]);
    if (QString::fromStdString(plans[i].name) == selected) row_of_selected = static_cast<int>(i);
  }
  if (row_of_selected < 0 && !plans.empty()) row_of_selected = 0;
  if (row_of_selected >= 0) {
    screws_->selectRow(row_of_selected);
    fillFields(plans[static_cast<std::size_t>(row_of_selected)]);
  } else {
    screws_->clearSelection();
    figures_->setText(tr("no screw planned: New screw, then click its entry and its target"));
  }
  filling_ = false;
}

void PlanningPanel::updateScrew(const workflow::PlannedScrew& screw) {
  for (std::size_t i = 0; i < plans_.size(); ++i) {
    if (plans_[i].name != screw.name) continue;
    plans_[i] = screw;
    filling_ = true;
    fillRow(static_cast<int>(i), screw);
    if (selectedScrew() == QString::fromStdString(screw.name)) fillFields(screw);
    filling_ = false;
  }
}

void PlanningPanel::setFiducials(const std::vector<workflow::FiducialPoint>& fiducials) {
  fiducials_->setRowCount(static_cast<int>(fiducials.size()));
  for (std::size_t i = 0; i < fiducials.size(); ++i) {
    const auto& f = fiducials[i];
    const auto row = static_cast<int>(i);
    fiducials_->setItem(row, 0, item(QString::fromStdString(f.label)));
    fiducials_->setItem(row, 1,
                        item(QStringLiteral("%1, %2, %3")
                                 .arg(f.position_ct.x(), 0, 'f', 1)
                                 .arg(f.position_ct.y(), 0, 'f', 1)
                                 .arg(f.position_ct.z(), 0, 'f', 1)));
    fiducials_->setItem(row, 2, item(QString::fromStdString(f.source)));
  }
}

QString PlanningPanel::selectedScrew() const {
  const auto rows = screws_->selectionModel()->selectedRows();
  if (rows.empty()) return {};
  const auto* i = screws_->item(rows.front().row(), 0);
  return i ? i->text() : QString();
}

void PlanningPanel::selectScrew(const QString& name) {
  for (int row = 0; row < screws_->rowCount(); ++row) {
    if (screws_->item(row, 0)->text() == name) {
      screws_->selectRow(row);
      return;
    }
  }
}

double PlanningPanel::newDiameter() const {
  return diameter_->value();
}

double PlanningPanel::newLength() const {
  return length_->value();
}

void PlanningPanel::setHint(const QString& text) {
  hint_->setText(text);
}

void PlanningPanel::setWindowLevel(double window, double level) {
  filling_ = true;
  window_->setValue(window);
  level_->setValue(level);
  filling_ = false;
}

bool PlanningPanel::trajectoryShown() const {
  return trajectory_->isChecked();
}

void PlanningPanel::setBusy(bool busy) {
  for (auto* b : buttons_) b->setEnabled(!busy);
}

void PlanningPanel::fillFields(const workflow::PlannedScrew& screw) {
  const bool was = filling_;
  filling_ = true;
  name_->setText(QString::fromStdString(screw.name));
  vertebra_->setText(QString::fromStdString(screw.vertebra));
  side_->setCurrentText(QString::fromStdString(screw.side));
  diameter_->setValue(screw.diameter_mm);
  length_->setValue(screw.length_mm);
  figures_->setText(figuresText(screw.figures));
  filling_ = was;
}

void PlanningPanel::emitEdit() {
  if (filling_) return;
  const QString name = selectedScrew();
  if (name.isEmpty()) return;
  emit screwEdited(name, name_->text().trimmed(), vertebra_->text().trimmed(), side_->currentText(),
                   diameter_->value(), length_->value());
}

QString PlanningPanel::figuresText(const nlohmann::json& f) {
  if (!f.is_object() || f.empty()) return tr("no figures yet");
  if (f.contains("error")) return QString::fromStdString(f.value("error", ""));
  QStringList lines;
  lines << tr("Length %1 mm, Ø %2 mm, in bone %3 mm")
               .arg(number(f, "length_mm"), number(f, "diameter_mm"),
                    f.contains("breach") && f["breach"].is_object() ? number(f["breach"], "length_in_bone_mm")
                                                                      : QStringLiteral("—"));
  if (f.contains("breach") && f["breach"].is_object()) {
    const auto& b = f["breach"];
    lines << tr("Cortical breach %1 mm (Gertzbein-Robbins %2) at %3 mm; entry %4 mm from the cortex")
                 .arg(number(b, "max_breach_mm"), QString::fromStdString(b.value("grade", "?")),
                      number(b, "depth_of_max_breach_mm"), number(b, "entry_to_bone_mm"));
  } else {
    lines << tr("Cortical breach: no bone model of this level");
  }
  if (f.contains("angles") && f["angles"].is_object()) {
    lines << tr("Medial %1°, cranial %2° (%3 side, vertebra %4)")
                 .arg(number(f["angles"], "medial_deg"), number(f["angles"], "cranial_deg"),
                      QString::fromStdString(f["angles"].value("side", "")),
                      QString::fromStdString(f.value("vertebra", nlohmann::json("")).is_string()
                                                 ? f["vertebra"].get<std::string>()
                                                 : ""));
  }
  lines << tr("Clearance: vessel %1, nerve %2, soft tissue %3 mm")
               .arg(clearanceText(f, "vessel"), clearanceText(f, "neural"), clearanceText(f, "soft_tissue"));
  if (f.contains("warnings") && f["warnings"].is_array()) {
    for (const auto& w : f["warnings"]) lines << QStringLiteral("⚠ ") + QString::fromStdString(w.get<std::string>());
  }
  return lines.join(QLatin1Char('\n'));
}

}  // namespace mrsns::gui
