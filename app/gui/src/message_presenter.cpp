#include "message_presenter.h"

#include <QMessageBox>

namespace mrsns::gui {

void DialogPresenter::present(const UserMessage& message) {
  const auto icon = message.kind == MessageKind::Error     ? QMessageBox::Critical
                    : message.kind == MessageKind::Warning ? QMessageBox::Warning
                                                           : QMessageBox::Information;
  auto* box = new QMessageBox(icon, message.title, message.text, QMessageBox::Ok, parent_);
  box->setObjectName(QStringLiteral("userMessage"));
  box->setAttribute(Qt::WA_DeleteOnClose);
  box->open();
}

bool DialogPresenter::confirm(const UserMessage& question) {
  QMessageBox box(QMessageBox::Question, question.title, question.text, QMessageBox::Yes | QMessageBox::No, parent_);
  box.setObjectName(QStringLiteral("userQuestion"));
  box.setDefaultButton(QMessageBox::No);
  return box.exec() == QMessageBox::Yes;
}

}  // namespace mrsns::gui
