#include "task_runner.h"

#include <QPointer>
#include <QtConcurrent/QtConcurrent>
#include <chrono>
#include <exception>
#include <mutex>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"

namespace mrsns::gui {

TaskRunner::TaskRunner(QObject* parent) : QObject(parent) {
  qRegisterMetaType<TaskOutcome>("mrsns::gui::TaskOutcome");
  connect(&watcher_, &QFutureWatcher<TaskOutcome>::finished, this, &TaskRunner::onFinished);
}

TaskRunner::~TaskRunner() {
  cancel();
  waitForFinished();
}

bool TaskRunner::start(const QString& name, TaskFunction work) {
  if (busy_) return false;
  busy_ = true;
  name_ = name;
  cancel_ = std::make_shared<std::atomic<bool>>(false);
  emit started(name);

  // Progress reports arrive from the worker at any rate; forward at most
  // ~20 per second so the event loop stays responsive.
  struct Throttle {
    std::mutex mutex;
    std::chrono::steady_clock::time_point last{};
  };
  auto throttle = std::make_shared<Throttle>();
  QPointer<TaskRunner> self(this);
  TaskControl control;
  control.cancel = cancel_.get();
  control.progress = [self, name, throttle](double fraction, const std::string& message) {
    {
      std::lock_guard lock(throttle->mutex);
      const auto now = std::chrono::steady_clock::now();
      if (fraction < 1.0 && now - throttle->last < std::chrono::milliseconds(50)) return;
      throttle->last = now;
    }
    const QString text = QString::fromStdString(message);
    QMetaObject::invokeMethod(
        self.data(),
        [self, name, fraction, text] {
          if (self) emit self->progressed(name, fraction, text);
        },
        Qt::QueuedConnection);
  };
  auto cancel_flag = cancel_;  // keeps the flag alive as long as the worker
  watcher_.setFuture(QtConcurrent::run([work = std::move(work), control, cancel_flag]() -> TaskOutcome {
    TaskOutcome outcome;
    try {
      outcome = work(control);
    } catch (const mrsns::Error& e) {
      outcome.ok = false;
      outcome.error = QString::fromStdString(e.what());
    } catch (const std::exception& e) {
      // Not a typed error: a defect, but still not a reason to crash the workstation.
      logger()->error("task failed with an unexpected exception: {}", e.what());
      outcome.ok = false;
      outcome.error =
          QString::fromStdString(std::string("Unexpected failure: ") + e.what() + ". Please report this with the log.");
    }
    if (!outcome.ok && cancel_flag->load()) outcome.cancelled = true;
    return outcome;
  }));
  return true;
}

void TaskRunner::cancel() {
  if (cancel_) cancel_->store(true);
}

void TaskRunner::waitForFinished() {
  watcher_.waitForFinished();
}

void TaskRunner::onFinished() {
  const TaskOutcome outcome = watcher_.result();
  const QString name = name_;
  busy_ = false;
  name_.clear();
  emit finished(name, outcome);
}

}  // namespace mrsns::gui
