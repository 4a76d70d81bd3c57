#pragma once
// The workstation's areas (paper 001 Fig. 4) as dock widgets that scroll, so
// no panel's content forces a minimum window size (a 1280x800 screen fits).
#include <QDockWidget>
#include <QMainWindow>
#include <QString>

namespace mrsns::gui {

/// A dock named `name` + "Dock" around `content` (named `name`), scrolling
/// along `scroll` only (the panel reflows to the other dimension).
QDockWidget* makeAreaDock(QMainWindow* window, const QString& title, const QString& name, QWidget* content,
                          Qt::Orientation scroll);

}  // namespace mrsns::gui
