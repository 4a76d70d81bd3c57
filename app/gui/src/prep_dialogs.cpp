#include "prep_dialogs.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDialog>
#include <QDialogButtonBox>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QInputDialog>
#include <QLineEdit>
#include <QListWidget>
#include <QPushButton>
#include <QRadioButton>
#include <QSpinBox>
#include <QVBoxLayout>
#include <filesystem>
#include <vector>

#include "mrsns/io/image_io.h"
#include "mrsns/workflow/session.h"

namespace mrsns::gui {

std::optional<nlohmann::json> askDicomSeries(QWidget* parent, const QString& folder) {
  nlohmann::json params = {{"path", folder.toStdString()}};
  const auto series = io::listDicomSeries(folder.toStdString());
  if (series.size() <= 1) return params;
  QStringList items;
  for (std::size_t i = 0; i < series.size(); ++i) {
    const auto& s = series[i];
    items << QObject::tr("%1: %2 \"%3\", %4 images (%5 x %6)")
                 .arg(i + 1)
                 .arg(QString::fromStdString(s.modality.empty() ? "?" : s.modality),
                      QString::fromStdString(s.description))
                 .arg(s.files)
                 .arg(s.columns)
                 .arg(s.rows);
  }
  bool ok = false;
  const QString chosen = QInputDialog::getItem(parent, QObject::tr("Import CT"),
                                               QObject::tr("The folder holds %1 series: which is the CT?")
                                                   .arg(series.size()),
                                               items, 0, false, &ok);
  if (!ok) return std::nullopt;
  params["series"] = series[static_cast<std::size_t>(items.indexOf(chosen))].uid;
  return params;
}

std::optional<nlohmann::json> askLabelMapImport(QWidget* parent, const workflow::Session& session) {
  QDialog dialog(parent);
  dialog.setWindowTitle(QObject::tr("Import label map"));
  dialog.setObjectName(QStringLiteral("labelMapDialog"));
  auto* form = new QFormLayout(&dialog);
  auto* path = new QLineEdit(&dialog);
  path->setObjectName(QStringLiteral("labelMapPath"));
  auto* browse = new QPushButton(QObject::tr("Browse…"), &dialog);
  auto* row = new QHBoxLayout;
  row->addWidget(path, 1);
  row->addWidget(browse);
  form->addRow(QObject::tr("File"), row);
  QObject::connect(browse, &QPushButton::clicked, &dialog, [&] {
    const QString file = QFileDialog::getOpenFileName(
        &dialog, QObject::tr("Label map"), QString(),
        QObject::tr("Label maps (*.nii *.nii.gz *.nrrd *.seg.nrrd *.mha *.mhd);;All files (*)"));
    if (!file.isEmpty()) path->setText(file);
  });
  auto* scheme = new QComboBox(&dialog);
  scheme->setObjectName(QStringLiteral("labelMapScheme"));
  scheme->addItem(QObject::tr("detect"), QStringLiteral("auto"));
  scheme->addItem(QObject::tr("TotalSegmentator"), QStringLiteral("totalsegmentator"));
  scheme->addItem(QObject::tr("VerSe"), QStringLiteral("verse"));
  scheme->addItem(QObject::tr("generic (label_N)"), QStringLiteral("generic"));
  form->addRow(QObject::tr("Label names"), scheme);
  auto* align = new QComboBox(&dialog);
  align->setObjectName(QStringLiteral("labelMapAlign"));
  align->addItem(QObject::tr("as its header places it"), QString());
  for (const auto& m : session.labelMaps()) {
    align->addItem(QObject::tr("onto the vertebrae of %1").arg(QString::fromStdString(m.id)),
                   QString::fromStdString(m.id));
  }
  align->setToolTip(QObject::tr("A crop saved with the whole image's origin: shift it by whole voxels onto the "
                                "vertebrae another label map of this CT shares with it"));
  form->addRow(QObject::tr("Place"), align);
  auto* resample = new QCheckBox(QObject::tr("Resample onto the CT's grid (nearest neighbour)"), &dialog);
  resample->setObjectName(QStringLiteral("labelMapResample"));
  form->addRow(QString(), resample);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &dialog);
  form->addRow(buttons);
  QObject::connect(buttons, &QDialogButtonBox::accepted, &dialog, &QDialog::accept);
  QObject::connect(buttons, &QDialogButtonBox::rejected, &dialog, &QDialog::reject);
  if (dialog.exec() != QDialog::Accepted || path->text().isEmpty()) return std::nullopt;
  nlohmann::json params = {{"path", path->text().toStdString()},
                           {"scheme", scheme->currentData().toString().toStdString()}};
  if (!align->currentData().toString().isEmpty()) params["align_to"] = align->currentData().toString().toStdString();
  if (resample->isChecked()) params["resample"] = true;
  return params;
}

std::optional<nlohmann::json> askMakeModels(QWidget* parent, const workflow::Session& session) {
  QDialog dialog(parent);
  dialog.setWindowTitle(QObject::tr("Make models"));
  dialog.setObjectName(QStringLiteral("makeModelsDialog"));
  auto* layout = new QVBoxLayout(&dialog);
  auto* from_labels = new QRadioButton(QObject::tr("From the labels of"), &dialog);
  auto* maps = new QComboBox(&dialog);
  for (const auto& m : session.labelMaps()) maps->addItem(QString::fromStdString(m.id));
  auto* top = new QHBoxLayout;
  top->addWidget(from_labels);
  top->addWidget(maps, 1);
  layout->addLayout(top);
  auto* labels = new QListWidget(&dialog);
  labels->setObjectName(QStringLiteral("makeModelsLabels"));
  layout->addWidget(labels);
  const auto fill = [&] {
    labels->clear();
    const auto map = session.labelMap(maps->currentText().toStdString());
    if (!map) return;
    for (const auto& l : map->labels) {
      auto* item = new QListWidgetItem(
          QObject::tr("%1 (%2, %3 voxels)").arg(QString::fromStdString(l.name), QString::fromStdString(l.role)).arg(l.voxels),
          labels);
      item->setData(Qt::UserRole, l.value);
      item->setFlags(item->flags() | Qt::ItemIsUserCheckable);
      item->setCheckState(l.role == "bone" || l.role == "vessel" || l.role == "neural" ? Qt::Checked : Qt::Unchecked);
    }
  };
  QObject::connect(maps, &QComboBox::currentTextChanged, &dialog, fill);
  fill();
  auto* from_threshold = new QRadioButton(QObject::tr("Bone above a threshold of the CT"), &dialog);
  auto* threshold = new QDoubleSpinBox(&dialog);
  threshold->setRange(-1000.0, 3000.0);
  threshold->setValue(250.0);
  threshold->setSuffix(QObject::tr(" HU"));
  auto* th_row = new QHBoxLayout;
  th_row->addWidget(from_threshold);
  th_row->addWidget(threshold);
  layout->addLayout(th_row);
  const bool have_maps = !session.labelMaps().empty();
  (have_maps ? from_labels : from_threshold)->setChecked(true);
  from_labels->setEnabled(have_maps);
  auto* form = new QFormLayout;
  auto* hmd = new QSpinBox(&dialog);
  hmd->setRange(0, 500000);
  hmd->setSingleStep(5000);
  hmd->setValue(20000);
  hmd->setSpecialValueText(QObject::tr("no headset copy"));
  form->addRow(QObject::tr("Headset copy, triangles at most"), hmd);
  layout->addLayout(form);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, &dialog);
  layout->addWidget(buttons);
  QObject::connect(buttons, &QDialogButtonBox::accepted, &dialog, &QDialog::accept);
  QObject::connect(buttons, &QDialogButtonBox::rejected, &dialog, &QDialog::reject);
  if (dialog.exec() != QDialog::Accepted) return std::nullopt;
  nlohmann::json params = {{"hmd_triangles", hmd->value()}};
  if (from_labels->isChecked()) {
    std::string chosen;
    for (int i = 0; i < labels->count(); ++i) {
      if (labels->item(i)->checkState() != Qt::Checked) continue;
      chosen += (chosen.empty() ? "" : ",") + std::to_string(labels->item(i)->data(Qt::UserRole).toInt());
    }
    if (chosen.empty()) return std::nullopt;
    params["source"] = "labels";
    params["label_map"] = maps->currentText().toStdString();
    params["labels"] = chosen;
  } else {
    params["source"] = "threshold";
    params["threshold_hu"] = threshold->value();
  }
  return params;
}

std::optional<nlohmann::json> askModelImport(QWidget* parent, const QString& path) {
  // The role decides how planning treats the model (bone holds a screw, vessels and nerves are kept clear of).
  const std::vector<workflow::ModelRole> roles = {workflow::ModelRole::Bone,   workflow::ModelRole::Vessel,
                                                  workflow::ModelRole::Neural, workflow::ModelRole::SoftTissue,
                                                  workflow::ModelRole::Fiducial, workflow::ModelRole::Other};
  const std::string stem = std::filesystem::path(path.toStdString()).stem().string();
  const workflow::ModelRole suggested = workflow::structureRole(stem);
  QStringList names;
  int current = 0;
  for (std::size_t i = 0; i < roles.size(); ++i) {
    names << QString::fromStdString(workflow::modelRoleName(roles[i]));
    if (roles[i] == suggested) current = static_cast<int>(i);
  }
  bool ok = false;
  const QString role = QInputDialog::getItem(
      parent, QObject::tr("Import model"),
      QObject::tr("What is %1? (planning keeps screws in bone and clear of vessels and nerves)")
          .arg(QString::fromStdString(stem)),
      names, current, false, &ok);
  if (!ok) return std::nullopt;
  return nlohmann::json{{"path", path.toStdString()}, {"role", role.toStdString()}};
}

}  // namespace mrsns::gui
