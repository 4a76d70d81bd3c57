#include "output_panel.h"

#include <QGridLayout>
#include <QGroupBox>
#include <QHeaderView>
#include <QLabel>
#include <QStringList>
#include <QTabWidget>
#include <QTreeWidget>
#include <QVBoxLayout>
#include <QVariant>
#include <cmath>

#include "plot_widget.h"

namespace mrsns::gui {
namespace {

const QColor kBlue(0x4f, 0xa3, 0xe0);
const QColor kGreen(0x5c, 0xc4, 0x8a);
const QColor kOrange(0xe8, 0xa0, 0x48);
const QColor kViolet(0xb0, 0x8c, 0xe8);

bool contains(const std::string& s, const char* what) {
  return s.find(what) != std::string::npos;
}

bool endsWith(const std::string& s, const char* suffix) {
  const std::string sfx(suffix);
  return s.size() >= sfx.size() && s.compare(s.size() - sfx.size(), sfx.size(), sfx) == 0;
}

QString unitOf(const std::string& key) {
  auto ends = [&](const char* suffix) {
    const std::string sfx(suffix);
    return key.size() >= sfx.size() && key.compare(key.size() - sfx.size(), sfx.size(), sfx) == 0;
  };
  if (ends("_mm")) return QStringLiteral(" mm");
  if (ends("_deg")) return QStringLiteral("°");
  if (ends("_ms")) return QStringLiteral(" ms");
  if (ends("_s")) return QStringLiteral(" s");
  if (ends("_px")) return QStringLiteral(" px");
  if (ends("_hz")) return QStringLiteral(" Hz");
  return {};
}

std::vector<double> numbers(const nlohmann::json& array) {
  std::vector<double> v;
  if (!array.is_array()) return v;
  v.reserve(array.size());
  for (const auto& e : array) {
    if (e.is_number()) {
      v.push_back(e.get<double>());
    } else if (e.is_null()) {
      v.push_back(std::nan(""));
    } else {
      return {};  // not a numeric series
    }
  }
  return v;
}

std::vector<double> indices(std::size_t n) {
  std::vector<double> x(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = static_cast<double>(i);
  return x;
}

}  // namespace

QString formatFigure(const std::string& key, const nlohmann::json& value) {
  if (value.is_number_float()) {
    const double v = value.get<double>();
    if (!std::isfinite(v)) return QStringLiteral("—");
    const double a = std::abs(v);
    const int decimals = a >= 100 ? 1 : a >= 1 ? 2 : 3;
    return QString::number(v, 'f', decimals) + unitOf(key);
  }
  if (value.is_number()) return QString::number(value.get<long long>()) + unitOf(key);
  if (value.is_boolean()) return value.get<bool>() ? QStringLiteral("yes") : QStringLiteral("no");
  if (value.is_string()) return QString::fromStdString(value.get<std::string>());
  if (value.is_array()) {
    // Short vectors (a size, a spacing, a point) read better spelled out.
    const auto v = numbers(value);
    if (!v.empty() && v.size() <= 4) {
      QStringList parts;
      for (double x : v) parts << QString::number(x, 'g', 5);
      return parts.join(QStringLiteral(", ")) + unitOf(key);
    }
    return QStringLiteral("[%1 values]").arg(value.size());
  }
  if (value.is_null()) return QStringLiteral("—");
  return QString::fromStdString(value.dump());
}

OutputPanel::OutputPanel(QWidget* parent) : QWidget(parent) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(6, 6, 6, 6);

  stop_banner_ = new QLabel(this);
  stop_banner_->setObjectName(QStringLiteral("navigationBanner"));
  stop_banner_->setWordWrap(true);
  stop_banner_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  stop_banner_->hide();
  layout->addWidget(stop_banner_);
  navigation_status_ = new QLabel(this);
  navigation_status_->setObjectName(QStringLiteral("navigationStatus"));
  navigation_status_->setWordWrap(true);
  navigation_status_->hide();
  layout->addWidget(navigation_status_);

  auto* headline = new QGroupBox(tr("Navigation parameters"), this);
  auto* grid = new QGridLayout(headline);
  grid->setHorizontalSpacing(12);
  const std::pair<const char*, QString> rows[] = {
      {"fre", tr("Registration FRE")},
      {"tre", tr("Registration TRE")},
      {"pivot", tr("Pivot calibration")},
      {"us_calibration", tr("US spatial calibration")},
      {"temporal_offset", tr("US temporal offset")},
      {"robot", tr("Robot calibration")},
      {"hmd", tr("HMD calibration")},
      {"deformation", tr("Soft-tissue model SD")},
      {"tip_to_tissue", tr("Drill tip → soft tissue")},
      {"placement", tr("Screw placement")},
      {"supervisor", tr("Supervisor")},
      {"latency", tr("Latency")},
  };
  int row = 0;
  for (const auto& [key, title] : rows) {
    auto* name = new QLabel(title, headline);
    name->setObjectName(QStringLiteral("readoutName"));
    auto* value = new QLabel(QStringLiteral("—"), headline);
    value->setObjectName(QStringLiteral("output_") + key);
    value->setProperty("severity", 0);
    value->setAlignment(Qt::AlignRight | Qt::AlignVCenter);
    value->setTextInteractionFlags(Qt::TextSelectableByMouse);
    // A long state (a robot stop's reason) wraps instead of widening the dock.
    value->setWordWrap(true);
    grid->addWidget(name, row, 0);
    grid->addWidget(value, row, 1);
    readouts_[QString::fromLatin1(key)] = value;
    ++row;
  }
  grid->setColumnStretch(1, 1);
  layout->addWidget(headline);

  plots_ = new QTabWidget(this);
  plots_->setObjectName(QStringLiteral("outputPlots"));
  auto makePlot = [&](const char* object_name, const QString& tab, const QString& title, const QString& x,
                      const QString& y) {
    auto* plot = new PlotWidget(plots_);
    plot->setObjectName(QString::fromLatin1(object_name));
    plot->setTitle(title);
    plot->setAxisLabels(x, y);
    plots_->addTab(plot, tab);
    return plot;
  };
  residual_plot_ =
      makePlot("plotResiduals", tr("Residuals"), tr("Calibration residual per frame"), tr("frame"), tr("mm"));
  latency_plot_ = makePlot("plotLatency", tr("Latency"), tr("Tracking → hologram latency"), tr("ms"), tr("count"));
  deformation_plot_ =
      makePlot("plotDeformation", tr("Deformation"), tr("Soft-tissue model error over time"), tr("time (s)"), tr("mm"));
  distance_plot_ = makePlot("plotDistance", tr("Distance"), tr("Drill tip to soft tissue"), tr("time (s)"), tr("mm"));
  plots_->setMinimumHeight(170);
  layout->addWidget(plots_, 1);

  auto* figures = new QGroupBox(tr("All step figures"), this);
  auto* figures_layout = new QVBoxLayout(figures);
  tree_ = new QTreeWidget(figures);
  tree_->setObjectName(QStringLiteral("outputFigures"));
  tree_->setColumnCount(2);
  tree_->setHeaderLabels({tr("Step / figure"), tr("Value")});
  tree_->header()->setSectionResizeMode(0, QHeaderView::ResizeToContents);
  tree_->setRootIsDecorated(true);
  tree_->setAlternatingRowColors(true);
  figures_layout->addWidget(tree_);
  layout->addWidget(figures, 1);
}

QString OutputPanel::readout(const QString& key) const {
  const auto it = readouts_.find(key);
  return it == readouts_.end() ? QString() : it->second->text();
}

void OutputPanel::setReadout(const QString& key, const QString& text, int severity) {
  const auto it = readouts_.find(key);
  if (it == readouts_.end()) return;
  it->second->setText(text);
  // The style sheet colours read-outs by this property (0 normal, 1 warn, 2 alarm).
  it->second->setProperty("severity", severity);
  it->second->style()->unpolish(it->second);
  it->second->style()->polish(it->second);
}

void OutputPanel::clear() {
  for (auto& [key, label] : readouts_) setReadout(key, QStringLiteral("—"));
  tree_->clear();
  residual_plot_->clear();
  latency_plot_->clear();
  deformation_plot_->clear();
  distance_plot_->clear();
  latencies_ms_.clear();
}

void OutputPanel::showSessionState(const nlohmann::json& state) {
  clear();
  if (!state.is_object() || !state.contains("steps") || !state["steps"].is_object()) return;
  for (const auto& [step, record] : state["steps"].items()) {
    const std::string status = record.is_object() && record.contains("status") && record["status"].is_string()
                                   ? record["status"].get<std::string>()
                                   : std::string();
    const nlohmann::json figures =
        record.is_object() && record.contains("figures") ? record["figures"] : nlohmann::json::object();
    showStepResult(step, status, figures);
  }
}

namespace {

void addFigureRows(QTreeWidgetItem* parent, const nlohmann::json& figures) {
  if (!figures.is_object()) return;
  for (auto it = figures.begin(); it != figures.end(); ++it) {
    // Matrices and simulation ground truth are for files, not for reading.
    if (it.key() == "transforms" || it.key() == "simulation_truth") continue;
    auto* child = new QTreeWidgetItem(parent);
    child->setText(0, QString::fromStdString(it.key()));
    if (it->is_object()) {
      addFigureRows(child, *it);
    } else {
      child->setText(1, formatFigure(it.key(), *it));
    }
  }
}

}  // namespace

void OutputPanel::showStepResult(const std::string& step, const std::string& status, const nlohmann::json& figures) {
  const QString step_name = QString::fromStdString(step);
  QTreeWidgetItem* item = nullptr;
  for (int i = 0; i < tree_->topLevelItemCount(); ++i) {
    if (tree_->topLevelItem(i)->data(0, Qt::UserRole).toString() == step_name) item = tree_->topLevelItem(i);
  }
  if (item == nullptr) {
    item = new QTreeWidgetItem(tree_);
    item->setData(0, Qt::UserRole, step_name);
  }
  qDeleteAll(item->takeChildren());
  item->setText(0, step_name);
  item->setText(1, QString::fromStdString(status));
  addFigureRows(item, figures);
  item->setExpanded(true);
  headlineFromFigures(step, figures);
  plotsFromFigures(step, figures);
}

namespace {

/// Scalar leaves of a (nested) figures object by dotted path, e.g. "surface.tre.rms".
void flatten(const nlohmann::json& j, const std::string& prefix,
             std::vector<std::pair<std::string, nlohmann::json>>& out) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      flatten(*it, prefix.empty() ? it.key() : prefix + "." + it.key(), out);
  } else if (j.is_number() || j.is_string() || j.is_boolean()) {
    out.emplace_back(prefix, j);
  }
}

/// The first leaf whose path equals one of `exact`, else contains one of `needles`.
const nlohmann::json* pick(const std::vector<std::pair<std::string, nlohmann::json>>& leaves,
                           std::initializer_list<const char*> exact, std::initializer_list<const char*> needles,
                           std::string* path) {
  for (const char* e : exact) {
    for (const auto& [p, v] : leaves) {
      if (p == e && v.is_number()) return *path = p, &v;
    }
  }
  for (const char* n : needles) {
    for (const auto& [p, v] : leaves) {
      if (contains(p, n) && v.is_number() && !contains(p, "expected") && !contains(p, "paper") &&
          !contains(p, "noise") && !contains(p, "predicted") && !contains(p, "truth"))
        return *path = p, &v;
    }
  }
  return nullptr;
}

}  // namespace

void OutputPanel::headlineFromFigures(const std::string& step, const nlohmann::json& figures) {
  std::vector<std::pair<std::string, nlohmann::json>> leaves;
  flatten(figures, "", leaves);
  std::string path;
  // Read-outs in mm whatever the figure's own name says (e.g. "surface.tre.rms").
  auto showMm = [&](const QString& readout, std::initializer_list<const char*> exact,
                    std::initializer_list<const char*> needles) {
    if (const auto* v = pick(leaves, exact, needles, &path)) {
      setReadout(readout, QString::number(v->get<double>(), 'f', 3) + QStringLiteral(" mm"));
    }
  };
  if (step == "registration") {
    showMm(QStringLiteral("fre"), {"landmarks.fre_rms_mm"}, {"fre"});
    // A registration acquired from the devices cannot measure its TRE (no truth): it predicts it at the
    // planned screws from its fiducials' scatter, and says so.
    setReadout(QStringLiteral("tre"), QStringLiteral("—"));
    if (figures.is_object() && figures.contains("tre_predicted_at_screws") &&
        figures["tre_predicted_at_screws"].value("rms", -1.0) >= 0.0) {
      setReadout(QStringLiteral("tre"),
                 QString::number(figures["tre_predicted_at_screws"]["rms"].get<double>(), 'f', 3) +
                     tr(" mm (predicted)"));
    } else {
      showMm(QStringLiteral("tre"), {"surface.tre.rms"}, {"tre.rms", "tre"});
    }
  } else if (contains(step, "pivot")) {
    showMm(QStringLiteral("pivot"), {"rms_mm"}, {"rms", "error"});
  } else if (step == "us-spatial-calibration") {
    showMm(QStringLiteral("us_calibration"),
           {"validation.reprojection_3d_mean_mm", "calibration.reprojection_3d_mean_mm"},
           {"reprojection", "rms", "error"});
  } else if (step == "us-temporal-calibration") {
    if (const auto* v = pick(leaves, {"tracker_lag_ms"}, {"lag", "offset"}, &path))
      setReadout(QStringLiteral("temporal_offset"), formatFigure(path, *v));
  } else if (step == "robot-calibration") {
    showMm(QStringLiteral("robot"), {"fre_rms_mm"}, {"rms", "error"});
  } else if (step == "hmd-calibration") {
    // With the headset: how well the views agree at the cube (no truth at the workstation); simulated: the error.
    showMm(QStringLiteral("hmd"), {"view_spread.at_cube_rms_mm", "tre_at_patient_mm", "rigid_rms_mm"},
           {"rms", "error"});
  } else if (step == "robot-placement") {
    // What the workstation knows: how many planned screws the arm drilled to their end (where they truly went is
    // measured outside it, on a phantom's CT or by mrsns-sim score).
    if (figures.is_object() && figures.contains("placed") && figures.contains("planned")) {
      const int placed = figures["placed"].get<int>(), planned = figures["planned"].get<int>();
      setReadout(QStringLiteral("placement"), tr("%1 of %2 placed").arg(placed).arg(planned), placed < planned ? 2 : 0);
    }
  }
  showMm(QStringLiteral("deformation"), {"deformation.posterior_sd_mean_mm"}, {"posterior_sd_mean"});
  showMm(QStringLiteral("tip_to_tissue"), {}, {"tissue", "tip_distance"});
  if (const auto* v = pick(leaves, {"mean_loop_latency_ms"}, {"latency"}, &path))
    setReadout(QStringLiteral("latency"), formatFigure(path, *v), v->get<double>() > 100.0 ? 1 : 0);
  if (figures.is_object() && figures.contains("robot_stopped") && figures["robot_stopped"].is_boolean()) {
    const bool stopped = figures["robot_stopped"].get<bool>();
    const std::string reason = figures.value("stop_reason", std::string());
    setSupervisorState(stopped ? tr("robot stopped: %1").arg(QString::fromStdString(reason)) : tr("ok"), !stopped);
  } else if (const auto* v = pick(leaves, {}, {"supervisor"}, &path)) {
    const QString text = formatFigure(path, *v);
    setSupervisorState(text, text.compare(QStringLiteral("ok"), Qt::CaseInsensitive) == 0);
  }
}

void OutputPanel::plotsFromFigures(const std::string& step, const nlohmann::json& figures, const std::string& prefix) {
  if (!figures.is_object()) return;
  const QString name = QString::fromStdString(step);
  // A figure "<key>_time_s" (or "time_s") of equal length gives the x axis.
  auto xFor = [&](const std::string& key, std::size_t n) {
    for (const std::string& candidate : {key + "_time_s", std::string("time_s"), std::string("times_s")}) {
      if (figures.contains(candidate)) {
        auto x = numbers(figures[candidate]);
        if (x.size() == n) return x;
      }
    }
    return indices(n);
  };
  // One step's series replace the plot once, sub-results included (the US
  // calibration's fitted and held-out frames share it).
  if (prefix.empty()) residuals_replaced_ = false;
  auto residualSeries = [&](const QString& series, const std::vector<double>& x, const std::vector<double>& y,
                            const QString& x_label, QColor color) {
    if (!residuals_replaced_) {
      // The plot shows the latest step's per-frame (or per-target) errors.
      residual_plot_->clear();
      residual_plot_->setTitle(tr("%1: errors").arg(name));
      residual_plot_->setAxisLabels(x_label, tr("mm"));
      residuals_replaced_ = true;
    }
    residual_plot_->setSeries(series, x, y, color);
  };
  const QColor palette[] = {kBlue, kOrange, kGreen, kViolet};
  // Colours follow the series already in the plot, across sub-results.
  auto nextColour = [&] { return palette[(residuals_replaced_ ? residual_plot_->seriesCount() : 0) % 4]; };
  for (auto it = figures.begin(); it != figures.end(); ++it) {
    const std::string& own_key = it.key();
    if (contains(own_key, "time_s")) continue;
    if (it->is_object()) {
      // Series of a sub-result (e.g. the navigation step's "deformation"),
      // with that sub-result's own *_time_s beside them.
      if (own_key != "transforms" && own_key != "simulation_truth") {
        plotsFromFigures(step, *it, prefix + own_key + ".");
      }
      continue;
    }
    const std::string key = prefix + own_key;
    const auto y = numbers(*it);
    if (y.empty() && it->is_array() && !it->empty() && (*it)[0].is_object()) {
      // Rows of objects (per target, per path, a lag curve): plot each *_mm
      // field against a *_ms field when there is one, else against the row.
      std::string x_field;
      for (auto f = (*it)[0].begin(); f != (*it)[0].end(); ++f) {
        if (f->is_number() && endsWith(f.key(), "_ms")) x_field = f.key();
      }
      for (auto f = (*it)[0].begin(); f != (*it)[0].end(); ++f) {
        if (!f->is_number() || !endsWith(f.key(), "_mm")) continue;
        std::vector<double> xs, ys;
        for (const auto& row : *it) {
          if (!row.is_object() || !row.contains(f.key()) || !row[f.key()].is_number()) continue;
          xs.push_back(x_field.empty() ? static_cast<double>(xs.size()) : row.value(x_field, 0.0));
          ys.push_back(row[f.key()].get<double>());
        }
        if (ys.empty()) continue;
        const QString x_label = x_field.empty() ? QString::fromStdString(key) : QString::fromStdString(x_field);
        residualSeries(QString::fromStdString(f.key()), xs, ys, x_label, nextColour());
      }
      continue;
    }
    if (y.empty()) continue;
    if (contains(key, "latenc")) {
      latencies_ms_ = y;
      latency_plot_->setHistogram(y, 20, kViolet);
    } else if (contains(key, "residual")) {
      residualSeries(QString::fromStdString(key), indices(y.size()), y, tr("frame"), nextColour());
    } else if (contains(key, "tissue") || contains(key, "distance")) {
      distance_plot_->setSeries(name, xFor(own_key, y.size()), y, kGreen);
    } else if (contains(key, "deformation") || contains(key, "error_over_time") || contains(key, "model_error")) {
      deformation_plot_->setSeries(name, xFor(own_key, y.size()), y, kOrange);
    }
  }
}

void OutputPanel::showLiveSample(double time_s, double tip_to_tissue_mm, double latency_ms,
                                 const QString& supervisor_state) {
  if (std::isfinite(tip_to_tissue_mm)) {
    setReadout(QStringLiteral("tip_to_tissue"), QString::number(tip_to_tissue_mm, 'f', 2) + QStringLiteral(" mm"),
               tip_to_tissue_mm < 2.0   ? 2
               : tip_to_tissue_mm < 5.0 ? 1
                                        : 0);
    // Named like the step, so the figures recorded at the end replace this series.
    distance_plot_->appendPoint(QStringLiteral("navigation"), time_s, tip_to_tissue_mm, kGreen);
  }
  if (std::isfinite(latency_ms)) {
    setReadout(QStringLiteral("latency"), QString::number(latency_ms, 'f', 1) + QStringLiteral(" ms"),
               latency_ms > 100.0 ? 1 : 0);
    latencies_ms_.push_back(latency_ms);
    if (latencies_ms_.size() > 5000) latencies_ms_.erase(latencies_ms_.begin());
    latency_plot_->setHistogram(latencies_ms_, 20, kViolet);
  }
  if (!supervisor_state.isEmpty()) setSupervisorState(supervisor_state, supervisor_state == QStringLiteral("ok"));
}

void OutputPanel::showDeformationSample(double time_s, double error_mm) {
  if (std::isfinite(error_mm)) deformation_plot_->appendPoint(QStringLiteral("navigation"), time_s, error_mm, kOrange);
}

void OutputPanel::beginLiveNavigation() {
  clearRobotStop();
  latencies_ms_.clear();
  latency_plot_->clear();
  distance_plot_->clear();
  deformation_plot_->clear();
  setNavigationStatus(tr("navigation starting…"));
}

void OutputPanel::showRobotStop(const QString& reason, const QString& when) {
  stop_banner_->setText(tr("ROBOT STOPPED\n%1\n%2").arg(reason, when));
  stop_banner_->show();
  setSupervisorState(tr("robot stopped"), false);
  readouts_[QStringLiteral("supervisor")]->setToolTip(reason);
}

void OutputPanel::clearRobotStop() {
  stop_banner_->clear();
  stop_banner_->hide();
}

QString OutputPanel::robotStopBanner() const {
  return stop_banner_->isHidden() ? QString() : stop_banner_->text();
}

void OutputPanel::setNavigationStatus(const QString& text) {
  navigation_status_->setText(text);
  navigation_status_->setVisible(!text.isEmpty());
}

QString OutputPanel::navigationStatus() const {
  return navigation_status_->text();
}

void OutputPanel::setSupervisorState(const QString& state, bool ok) {
  setReadout(QStringLiteral("supervisor"), state, ok ? 0 : 2);
}

}  // namespace mrsns::gui
