#pragma once
// The output area of paper 001 Fig. 4: the figures that matter during
// navigation (registration FRE/TRE, calibration errors, drill tip to soft
// tissue, supervisor state, latency) as large read-outs, every step's
// figures in a tree, and plots where a curve says more than a number.
#include <QWidget>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

class QLabel;
class QTreeWidget;
class QTabWidget;

namespace mrsns::gui {

class PlotWidget;

class OutputPanel : public QWidget {
  Q_OBJECT
 public:
  explicit OutputPanel(QWidget* parent = nullptr);

  /// Shows one step's result: its figures in the tree, the headline read-outs
  /// it provides, and any per-frame series it carries in the plots.
  void showStepResult(const std::string& step, const std::string& status, const nlohmann::json& figures);
  /// Shows every step recorded in a session state ({"steps": {name: {...}}}).
  void showSessionState(const nlohmann::json& state);
  /// Live values from the navigation loop: the tip-to-tissue distance over
  /// time and the loop latency histogram grow by one sample (NaN: none).
  void showLiveSample(double time_s, double tip_to_tissue_mm, double latency_ms, const QString& supervisor_state);
  /// One soft-tissue model error sample (posterior vs ground truth, mm) during navigation.
  void showDeformationSample(double time_s, double error_mm);
  /// A live navigation starts: its plots begin empty, no banner.
  void beginLiveNavigation();
  /// The red banner of a robot stop (the reason and when), shown until the
  /// robot is re-armed or a new navigation starts. No dialog: nobody should
  /// have to click OK during navigation.
  void showRobotStop(const QString& reason, const QString& when);
  void clearRobotStop();
  /// The banner's text; empty while it is hidden.
  [[nodiscard]] QString robotStopBanner() const;
  /// One line on the running navigation (time, batches, recording).
  void setNavigationStatus(const QString& text);
  [[nodiscard]] QString navigationStatus() const;
  void setSupervisorState(const QString& state, bool ok);
  void clear();

  /// The read-out text of a headline figure ("fre", "tre", "us_calibration",
  /// "temporal_offset", "pivot", "hmd", "robot", "deformation",
  /// "tip_to_tissue", "placement", "supervisor", "latency"); empty when unknown.
  [[nodiscard]] QString readout(const QString& key) const;
  PlotWidget* residualPlot() const { return residual_plot_; }
  PlotWidget* latencyPlot() const { return latency_plot_; }
  PlotWidget* deformationPlot() const { return deformation_plot_; }
  PlotWidget* distancePlot() const { return distance_plot_; }

 private:
  void setReadout(const QString& key, const QString& text, int severity = 0);
  void headlineFromFigures(const std::string& step, const nlohmann::json& figures);
  /// `prefix` names the sub-result the figures come from ("deformation."):
  /// series are recognised by their full dotted name.
  void plotsFromFigures(const std::string& step, const nlohmann::json& figures, const std::string& prefix = {});
  bool residuals_replaced_ = false;  // within one plotsFromFigures call tree

  std::map<QString, QLabel*> readouts_;
  QLabel* stop_banner_ = nullptr;
  QLabel* navigation_status_ = nullptr;
  QTreeWidget* tree_ = nullptr;
  QTabWidget* plots_ = nullptr;
  PlotWidget* residual_plot_ = nullptr;
  PlotWidget* latency_plot_ = nullptr;
  PlotWidget* deformation_plot_ = nullptr;
  PlotWidget* distance_plot_ = nullptr;
  std::vector<double> latencies_ms_;
};

/// Formats a figure value for a read-out: numbers with 3 significant
/// decimals and their unit from the key's suffix (_mm, _deg, _s, _ms, _px).
QString formatFigure(const std::string& key, const nlohmann::json& value);

}  // namespace mrsns::gui
