#pragma once
// The function area of paper 001 Fig. 4: robot (placement, stop), MR
// (hologram stream to the HMD on/off), ultrasound (live slice) and display
// toggles, plus the function steps (navigation, robot-assisted placement).
#include <QString>
#include <QWidget>
#include <string>
#include <vector>

#include "step_list.h"

class QCheckBox;
class QComboBox;
class QLabel;
class QPushButton;
class QSpinBox;

namespace mrsns::gui {

/// The groups of scene objects a user shows or hides.
enum class DisplayLayer { Vertebrae, SoftTissue, PlannedPaths, Tools, Ultrasound, SliceViews };

class FunctionPanel : public QWidget {
  Q_OBJECT
 public:
  explicit FunctionPanel(QWidget* parent = nullptr);

  void setSteps(const std::vector<StepEntry>& steps);
  void setStepState(const QString& step, StepState state, const QString& detail = {});
  void setBusy(bool busy);

  /// Reflects live navigation (the button stays in sync when starting fails).
  void setLiveNavigation(bool on);
  /// Reflects the hologram stream (the button stays in sync when starting fails).
  void setStreaming(bool on, const QString& detail);
  [[nodiscard]] int streamPort() const;
  /// The headset client the stream is set up for (a tracking::hologramClientPresets() name).
  [[nodiscard]] std::string streamClient() const;
  [[nodiscard]] bool layerVisible(DisplayLayer layer) const;

  /// Reflects the WebXR client's server (the button stays in sync when starting fails); `detail` shows the
  /// page's address and pairing code.
  void setWebXr(bool on, const QString& detail);
  /// Shown on hovering the WebXR status (who serves the page, headsets paired, the certificate).
  void setWebXrDetail(const QString& detail);
  [[nodiscard]] int webXrPort() const;
  /// Served on every interface (a headset on the lab's network) rather than this machine only.
  [[nodiscard]] bool webXrFromNetwork() const;

 signals:
  void runStepRequested(const QString& step);
  void hologramStreamToggled(bool on);
  void webXrToggled(bool on);
  void liveNavigationToggled(bool on);
  void robotRearmRequested();
  void robotStopRequested();
  void layerToggled(mrsns::gui::DisplayLayer layer, bool visible);
  void resetCameraRequested();

 private:
  StepList* navigation_ = nullptr;
  QPushButton* stop_ = nullptr;
  QPushButton* live_ = nullptr;
  QPushButton* rearm_ = nullptr;
  QWidget* live_row_ = nullptr;
  QPushButton* stream_button_ = nullptr;
  QSpinBox* stream_port_ = nullptr;
  QComboBox* stream_client_ = nullptr;
  QLabel* stream_status_ = nullptr;
  QPushButton* webxr_button_ = nullptr;
  QSpinBox* webxr_port_ = nullptr;
  QCheckBox* webxr_network_ = nullptr;
  QLabel* webxr_status_ = nullptr;
  std::vector<std::pair<DisplayLayer, QCheckBox*>> layers_;
};

}  // namespace mrsns::gui
