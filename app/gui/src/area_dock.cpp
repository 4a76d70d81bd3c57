#include "area_dock.h"

#include <QFrame>
#include <QScrollArea>

namespace mrsns::gui {

QDockWidget* makeAreaDock(QMainWindow* window, const QString& title, const QString& name, QWidget* content,
                          Qt::Orientation scroll) {
  auto* dock = new QDockWidget(title, window);
  dock->setObjectName(name + QStringLiteral("Dock"));
  dock->setFeatures(QDockWidget::DockWidgetMovable | QDockWidget::DockWidgetFloatable |
                    QDockWidget::DockWidgetClosable);
  content->setObjectName(name);
  auto* area = new QScrollArea(dock);
  area->setWidget(content);
  area->setWidgetResizable(true);
  if (scroll == Qt::Vertical) {
    area->setHorizontalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  } else {
    area->setVerticalScrollBarPolicy(Qt::ScrollBarAlwaysOff);
  }
  area->setFrameShape(QFrame::NoFrame);
  dock->setWidget(area);
  return dock;
}

}  // namespace mrsns::gui
