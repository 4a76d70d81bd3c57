#include "function_panel.h"

#include <QCheckBox>
#include <QComboBox>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QSpinBox>
#include <QVBoxLayout>
#include <QVariant>

#include "mrsns/tracking/hologram_client_preset.h"

namespace mrsns::gui {

FunctionPanel::FunctionPanel(QWidget* parent) : QWidget(parent) {
  // Docked under the display: the groups side by side, like a control strip.
  auto* layout = new QHBoxLayout(this);
  layout->setContentsMargins(6, 2, 6, 6);
  layout->setSpacing(10);

  navigation_ = new StepList(tr("Navigation and robot"), this);
  live_ = new QPushButton(tr("Start live navigation"), navigation_);
  live_->setMinimumWidth(150);
  live_->setObjectName(QStringLiteral("navigationLive"));
  live_->setCheckable(true);
  live_->setToolTip(
      tr("Run the navigation loop until stopped: tools move in the 3D view, every stream is "
         "recorded into the session, a robot stop shows its reason in the output area"));
  connect(live_, &QPushButton::toggled, this, &FunctionPanel::liveNavigationToggled);
  rearm_ = new QPushButton(tr("Re-arm"), navigation_);
  rearm_->setObjectName(QStringLiteral("robotRearm"));
  rearm_->setToolTip(
      tr("Let the robot move again once tracking is back (it stops again at once if not); after Stop robot, "
         "resume the placement"));
  rearm_->setEnabled(false);
  connect(rearm_, &QPushButton::clicked, this, &FunctionPanel::robotRearmRequested);
  stop_ = new QPushButton(tr("Stop robot"), navigation_);
  auto* stop = stop_;
  stop->setObjectName(QStringLiteral("robotStop"));
  stop->setProperty("danger", true);
  stop->setToolTip(
      tr("During live navigation: the supervisor stops the arm, navigation goes on (Re-arm resumes). "
         "Otherwise cancels the running robot task (Esc)"));
  // Live navigation and re-arm share a row: the function strip stays short.
  live_row_ = new QWidget(navigation_);
  auto* live_layout = new QHBoxLayout(live_row_);
  live_layout->setContentsMargins(0, 0, 0, 0);
  live_layout->addWidget(live_, 2);
  live_layout->addWidget(rearm_, 1);
  navigation_->addWidgetRow(live_row_);
  navigation_->addWidgetRow(stop);
  connect(stop, &QPushButton::clicked, this, &FunctionPanel::robotStopRequested);
  layout->addWidget(navigation_);
  connect(navigation_, &StepList::runRequested, this, &FunctionPanel::runStepRequested);

  auto* mr = new QGroupBox(tr("Mixed reality"), this);
  auto* mr_layout = new QGridLayout(mr);
  stream_button_ = new QPushButton(tr("Hologram stream"), mr);
  stream_button_->setObjectName(QStringLiteral("hologramStream"));
  stream_button_->setCheckable(true);
  stream_button_->setToolTip(tr("Serve the models and their poses to the HMD over OpenIGTLink (127.0.0.1)"));
  stream_port_ = new QSpinBox(mr);
  stream_port_->setObjectName(QStringLiteral("hologramPort"));
  stream_port_->setRange(1024, 65535);
  stream_port_->setValue(18945);
  stream_port_->setPrefix(tr("port "));
  // The client decides the header version, units, handedness and messages it can read; a pose right in one is
  // mirrored or scaled in another (tracking/hologram_client_preset.h).
  stream_client_ = new QComboBox(mr);
  stream_client_->setObjectName(QStringLiteral("hologramClient"));
  stream_client_->setToolTip(tr("The headset client: the stream is sent in the form it reads"));
  for (const auto& preset : tracking::hologramClientPresets()) {
    stream_client_->addItem(QString::fromStdString(preset.name));
    stream_client_->setItemData(stream_client_->count() - 1, QString::fromStdString(preset.description),
                                Qt::ToolTipRole);
  }
  stream_status_ = new QLabel(tr("off"), mr);
  stream_status_->setObjectName(QStringLiteral("hologramStatus"));
  mr_layout->addWidget(stream_button_, 0, 0);
  mr_layout->addWidget(stream_port_, 0, 1);
  mr_layout->addWidget(new QLabel(tr("Client"), mr), 1, 0);
  mr_layout->addWidget(stream_client_, 1, 1);
  mr_layout->addWidget(stream_status_, 2, 0, 1, 2);
  connect(stream_button_, &QPushButton::toggled, this, &FunctionPanel::hologramStreamToggled);
  // The WebXR client: a page the headset's browser opens, admitted by the pairing code shown here.
  webxr_button_ = new QPushButton(tr("WebXR client"), mr);
  webxr_button_->setObjectName(QStringLiteral("webxrClient"));
  webxr_button_->setCheckable(true);
  webxr_button_->setToolTip(tr("Serve the holograms to a headset's browser (HTTPS page, no app to install); the "
                               "headset enters the pairing code shown below"));
  webxr_port_ = new QSpinBox(mr);
  webxr_port_->setObjectName(QStringLiteral("webxrPort"));
  webxr_port_->setRange(1024, 65535);
  webxr_port_->setValue(8443);
  webxr_port_->setPrefix(tr("port "));
  webxr_network_ = new QCheckBox(tr("Reachable from the network"), mr);
  webxr_network_->setObjectName(QStringLiteral("webxrNetwork"));
  webxr_network_->setToolTip(tr("Off: this machine only (127.0.0.1). On: every interface, for a headset on the "
                                "lab's network (it still needs the pairing code)"));
  webxr_status_ = new QLabel(tr("off"), mr);
  webxr_status_->setObjectName(QStringLiteral("webxrStatus"));
  webxr_status_->setWordWrap(true);
  webxr_status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  mr_layout->addWidget(webxr_button_, 3, 0);
  mr_layout->addWidget(webxr_port_, 3, 1);
  mr_layout->addWidget(webxr_network_, 4, 0, 1, 2);
  mr_layout->addWidget(webxr_status_, 5, 0, 1, 2);
  connect(webxr_button_, &QPushButton::toggled, this, &FunctionPanel::webXrToggled);
  layout->addWidget(mr);

  auto* display = new QGroupBox(tr("Ultrasound and display"), this);
  auto* display_layout = new QGridLayout(display);
  const std::tuple<DisplayLayer, const char*, QString> layers[] = {
      {DisplayLayer::Ultrasound, "layerUltrasound", tr("Live US slice")},
      {DisplayLayer::Vertebrae, "layerVertebrae", tr("Vertebrae")},
      {DisplayLayer::SoftTissue, "layerSoftTissue", tr("Soft tissue")},
      {DisplayLayer::PlannedPaths, "layerPaths", tr("Planned paths")},
      {DisplayLayer::Tools, "layerTools", tr("Tools")},
      {DisplayLayer::SliceViews, "layerSliceViews", tr("Slice views")},
  };
  int i = 0;
  for (const auto& [layer, name, text] : layers) {
    auto* box = new QCheckBox(text, display);
    box->setObjectName(QString::fromLatin1(name));
    box->setChecked(true);
    display_layout->addWidget(box, i / 3, i % 3);
    layers_.emplace_back(layer, box);
    connect(box, &QCheckBox::toggled, this, [this, l = layer](bool on) { emit layerToggled(l, on); });
    ++i;
  }
  auto* reset = new QPushButton(tr("Reset camera"), display);
  reset->setObjectName(QStringLiteral("resetCamera"));
  reset->setToolTip(tr("Fit the 3D view to the scene (Home)"));
  display_layout->addWidget(reset, 0, 3, 2, 1);
  connect(reset, &QPushButton::clicked, this, &FunctionPanel::resetCameraRequested);
  layout->addWidget(display);
  layout->addStretch(1);
}

void FunctionPanel::setSteps(const std::vector<StepEntry>& steps) {
  for (const auto& step : steps) {
    if (step.area != QLatin1String("function")) continue;
    if (!navigation_->hasStep(step.name)) navigation_->addStep(step);
  }
  // Live navigation, re-arm and Stop stay below the steps.
  navigation_->addWidgetRow(live_row_);
  navigation_->addWidgetRow(stop_);
}

void FunctionPanel::setStepState(const QString& step, StepState state, const QString& detail) {
  navigation_->setStepState(step, state, detail);
}

void FunctionPanel::setBusy(bool busy) {
  navigation_->setBusy(busy);
}

void FunctionPanel::setLiveNavigation(bool on) {
  const QSignalBlocker block(live_);
  live_->setChecked(on);
  live_->setText(on ? tr("Stop live navigation") : tr("Start live navigation"));
  rearm_->setEnabled(on);
}

void FunctionPanel::setStreaming(bool on, const QString& detail) {
  const QSignalBlocker block(stream_button_);
  stream_button_->setChecked(on);
  stream_port_->setEnabled(!on);
  stream_client_->setEnabled(!on);
  stream_status_->setText(detail);
}

void FunctionPanel::setWebXr(bool on, const QString& detail) {
  const QSignalBlocker block(webxr_button_);
  webxr_button_->setChecked(on);
  webxr_port_->setEnabled(!on);
  webxr_network_->setEnabled(!on);
  webxr_status_->setText(detail);
  if (!on) webxr_status_->setToolTip(QString());
}

void FunctionPanel::setWebXrDetail(const QString& detail) {
  webxr_status_->setToolTip(detail);
}

int FunctionPanel::webXrPort() const {
  return webxr_port_->value();
}

bool FunctionPanel::webXrFromNetwork() const {
  return webxr_network_->isChecked();
}

int FunctionPanel::streamPort() const {
  return stream_port_->value();
}

std::string FunctionPanel::streamClient() const {
  return stream_client_->currentText().toStdString();
}

bool FunctionPanel::layerVisible(DisplayLayer layer) const {
  for (const auto& [l, box] : layers_) {
    if (l == layer) return box->isChecked();
  }
  return false;
}

}  // namespace mrsns::gui
