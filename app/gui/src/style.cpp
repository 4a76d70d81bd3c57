// The workstation's look: a dark theme (the OR is dim and the 3D view is
// the brightest thing on screen), read-outs large and coloured by severity.
#include "main_window.h"

namespace mrsns::gui {

QString workstationStyleSheet() {
  return QStringLiteral(R"(
QMainWindow, QWidget { background: #23272e; color: #d7dde4; }
QMenuBar { background: #1b1e23; }
QMenuBar::item:selected, QMenu::item:selected { background: #2f6fa8; }
QMenu { background: #1b1e23; border: 1px solid #3a4049; }
QDockWidget { titlebar-close-icon: none; font-weight: bold; }
QDockWidget::title { background: #1b1e23; padding: 6px; text-align: left; }
QGroupBox { border: 1px solid #3a4049; border-radius: 4px; margin-top: 14px; padding-top: 6px; }
QGroupBox::title { subcontrol-origin: margin; left: 8px; padding: 0 4px; color: #8fb8de; font-weight: bold; }
QPushButton { background: #333a44; border: 1px solid #465061; border-radius: 3px; padding: 5px 10px; }
QPushButton:hover { background: #3d4652; }
QPushButton:pressed, QPushButton:checked { background: #2f6fa8; border-color: #4f8fc8; }
QPushButton:disabled { color: #6b7480; }
QPushButton[danger="true"] { background: #7a2a2a; border-color: #a33b3b; font-weight: bold; }
QPushButton[danger="true"]:hover { background: #943333; }
QLabel[stepState="done"] { color: #6fd08c; }
QLabel[stepState="failed"] { color: #ef7a6a; }
QLabel[stepState="running"] { color: #e8c05a; }
QLabel[stepState="none"] { color: #7d8693; }
QLabel#readoutName { color: #9aa5b1; }
QLabel#sliceTitle { color: #8fb8de; font-weight: bold; padding: 2px 4px; background: #1b1e23; }
QLabel[severity="0"] { font-size: 15px; font-weight: bold; color: #e6edf3; }
QLabel[severity="1"] { font-size: 15px; font-weight: bold; color: #e8c05a; }
QLabel[severity="2"] { font-size: 15px; font-weight: bold; color: #ff6b5a; }
QLabel#navigationBanner { background: #b3261e; color: #ffffff; font-size: 15px; font-weight: bold; padding: 8px; border-radius: 4px; }
QLabel#navigationStatus { color: #9aa5b1; }
QLabel[placeholder="true"] { background: #15181c; color: #7d8693; }
QTreeWidget { background: #1b1e23; alternate-background-color: #20242a; border: 1px solid #3a4049; }
QHeaderView::section { background: #2a2f37; color: #9aa5b1; border: none; padding: 4px; }
QTabWidget::pane { border: 1px solid #3a4049; }
QTabBar::tab { background: #2a2f37; padding: 5px 10px; border-top-left-radius: 3px; border-top-right-radius: 3px; }
QTabBar::tab:selected { background: #2f6fa8; }
QProgressBar { border: 1px solid #465061; border-radius: 3px; background: #1b1e23; height: 12px; }
QProgressBar::chunk { background: #4f8fc8; }
QStatusBar { background: #1b1e23; }
QSpinBox, QCheckBox { padding: 2px; }
QScrollArea { border: none; }
)");
}

}  // namespace mrsns::gui
