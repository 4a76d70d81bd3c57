#pragma once
// How the window tells the user something went wrong (or right). The window
// never calls QMessageBox directly: tests inject a recorder and read what a
// user would have seen, without a modal dialog blocking the event loop.
#include <QString>
#include <QWidget>
#include <vector>

namespace mrsns::gui {

enum class MessageKind { Information, Warning, Error };

struct UserMessage {
  MessageKind kind = MessageKind::Information;
  QString title;
  /// What happened and what to do about it.
  QString text;
};

class MessagePresenter {
 public:
  virtual ~MessagePresenter() = default;
  virtual void present(const UserMessage& message) = 0;
  /// A yes/no question before something that cannot be undone in place (replacing the patient's CT); true
  /// for yes.
  virtual bool confirm(const UserMessage& question) = 0;
};

/// Shows a window-modal QMessageBox that does not block the caller (open(),
/// not exec()), so worker results keep arriving while it is up.
class DialogPresenter : public MessagePresenter {
 public:
  explicit DialogPresenter(QWidget* parent) : parent_(parent) {}
  void present(const UserMessage& message) override;
  /// Modal: the action waits for the answer.
  bool confirm(const UserMessage& question) override;

 private:
  QWidget* parent_;
};

/// Keeps every message and question; for tests and for the headless screenshot mode. Questions are answered
/// with `answer` (no, unless a test says otherwise).
class RecordingPresenter : public MessagePresenter {
 public:
  void present(const UserMessage& message) override { messages.push_back(message); }
  bool confirm(const UserMessage& question) override {
    questions.push_back(question);
    return answer;
  }
  std::vector<UserMessage> messages;
  std::vector<UserMessage> questions;
  bool answer = false;
};

}  // namespace mrsns::gui
