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

}  // namespace mrsns::gui
