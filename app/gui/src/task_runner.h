#pragma once
// Runs one long task (a workflow step, a file import) at a time on a worker
// thread, forwards its progress to the GUI thread, and lets the user cancel
// it. Whatever the task throws is caught on the worker and delivered as a
// failed outcome: nothing a task does can take the window down.
#include <QFutureWatcher>
#include <QObject>
#include <QString>
#include <atomic>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace mrsns::gui {

struct TaskOutcome {
  bool ok = false;
  bool cancelled = false;
  /// One line for the status bar and the log.
  QString summary;
  nlohmann::json figures = nlohmann::json::object();
  std::vector<std::string> outputs;
  /// When the task threw: the error's message (what was wrong, what to do).
  QString error;
};

/// What a task gets: a progress callback (any thread; throttled to the GUI)
/// and the cancel flag it must poll.
struct TaskControl {
  std::function<void(double fraction, const std::string& message)> progress;
  const std::atomic<bool>* cancel = nullptr;
};

using TaskFunction = std::function<TaskOutcome(const TaskControl&)>;

class TaskRunner : public QObject {
  Q_OBJECT
 public:
  explicit TaskRunner(QObject* parent = nullptr);
  ~TaskRunner() override;

  /// Starts `work` on the thread pool; false (and nothing started) while
  /// another task runs.
  bool start(const QString& name, TaskFunction work);
  void cancel();
  [[nodiscard]] bool busy() const { return busy_; }
  [[nodiscard]] QString currentTask() const { return name_; }
  /// Blocks until the running task (if any) has finished; for shutdown.
  void waitForFinished();

 signals:
  void started(const QString& name);
  void progressed(const QString& name, double fraction, const QString& message);
  void finished(const QString& name, const mrsns::gui::TaskOutcome& outcome);

 private:
  void onFinished();

  QFutureWatcher<TaskOutcome> watcher_;
  std::shared_ptr<std::atomic<bool>> cancel_;
  QString name_;
  bool busy_ = false;
};

}  // namespace mrsns::gui

Q_DECLARE_METATYPE(mrsns::gui::TaskOutcome)
