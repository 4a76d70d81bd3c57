#pragma once
// A column of workflow steps, each a Run button with its status beside it
// (not run / running / done with its headline figure / failed). Panels build
// one per group of steps; the main window runs what they ask for.
#include <QGroupBox>
#include <QString>
#include <map>
#include <nlohmann/json.hpp>
#include <vector>

class QLabel;
class QPushButton;

namespace mrsns::gui {

struct StepEntry {
  QString name;   ///< workflow step name, e.g. "registration"
  QString title;  ///< what the user reads
  QString area;   ///< "preparation" or "function"
  QString description;
  QString group;  ///< "data", "planning", "devices", "registration", "calibration", "navigation"
};

enum class StepState { NotRun, Running, Done, Failed, Cancelled };

class StepList : public QGroupBox {
  Q_OBJECT
 public:
  StepList(const QString& title, QWidget* parent = nullptr);

  /// Adds a row; its button is named "step_<name>" (for tests and shortcuts).
  QPushButton* addStep(const StepEntry& step);
  /// Adds a widget spanning the row below the last one (e.g. a button that is not a step).
  void addWidgetRow(QWidget* widget);
  [[nodiscard]] bool hasStep(const QString& name) const { return rows_.count(name) != 0; }
  [[nodiscard]] bool isEmpty() const { return rows_.empty(); }
  void setStepState(const QString& name, StepState state, const QString& detail = {});
  /// Disables every Run button while a task runs (one task at a time).
  void setBusy(bool busy);

 signals:
  void runRequested(const QString& step);

 private:
  struct Row {
    QPushButton* button = nullptr;
    QLabel* status = nullptr;
  };
  std::map<QString, Row> rows_;
  int next_row_ = 0;
};

/// The headline figure shown next to a step's button ("0.245 mm": FRE, reprojection error, lag, RMS).
QString stepHeadline(const nlohmann::json& figures);

}  // namespace mrsns::gui
