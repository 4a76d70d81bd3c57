#pragma once
// Starts and stops the simulated operating room (`mrsns-sim run`) as a
// separate process for a demonstration, and tells the window where it
// listens once it is ready. The workstation never links the simulation: it
// only starts the program and then talks to it as to a PlusServer and a UR
// controller. The truth file goes to a temporary folder outside the session.
#include <QObject>
#include <QString>
#include <memory>

class QProcess;
class QTimer;
class QTemporaryDir;

namespace mrsns::gui {

struct SimulatedRoomEndpoints {
  QString host;
  int plus_port = 0;
  int rtde_port = 0;
  int dashboard_port = 0;
  int realtime_port = 0;
  /// The port of the workstation's hologram stream the room's headset connects to (0: the room has none).
  int hmd_port = 0;
};

class SimulatedRoom : public QObject {
  Q_OBJECT
 public:
  explicit SimulatedRoom(QObject* parent = nullptr);
  ~SimulatedRoom() override;

  /// Where mrsns-sim is: beside the mrsns executable (installed), or in the
  /// build tree's app/sim; empty when not found.
  [[nodiscard]] static QString findProgram();
  /// The bundled scenario of the phantom trial.
  [[nodiscard]] static QString defaultScenario();

  /// Starts `mrsns-sim run` on `scenario` with ports of the system's choice;
  /// false with `why` when the program or the scenario is missing or another
  /// room runs. ready() or failed() follows.
  bool start(const QString& scenario, QString& why);
  /// SIGTERM, then waits up to 5 s (the room writes its truth and exits).
  void stop();
  [[nodiscard]] bool running() const;
  [[nodiscard]] bool ready() const { return ready_; }
  [[nodiscard]] const SimulatedRoomEndpoints& endpoints() const { return endpoints_; }
  [[nodiscard]] QString truthFile() const;

 signals:
  void becameReady(const mrsns::gui::SimulatedRoomEndpoints& endpoints);
  /// The process could not start, or ended before it was ready or while running (its last stderr line).
  void failed(const QString& why);
  void stopped();

 private:
  void pollReady();
  QProcess* process_ = nullptr;
  QTimer* poll_ = nullptr;
  std::unique_ptr<QTemporaryDir> dir_;
  bool ready_ = false;
  bool stopping_ = false;
  SimulatedRoomEndpoints endpoints_;
};

}  // namespace mrsns::gui
