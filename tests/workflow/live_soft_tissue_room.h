#pragma once
// A simulated operating room (simulation::OperatingRoom, in process, behind its PlusServer) for the navigation
// loop's live soft tissue: a carotid-like vessel whose shape model has one mode (the whole vessel moves
// sideways, along the model's x, 5 mm per SD), a patient reference, and a probe held by a hand that sweeps
// transverse planes over the vessel at 20 frames/s (320 x 320 pixels of 0.1 mm). The model's frame is the
// CT's shifted by kModelInCt.
//
// Noise model: tracker 0.12 mm RMS position and 0.05 deg RMS orientation per sample (the scenario's default),
// hand tremor 0.3 mm RMS at 8-12 Hz, B-mode speckle and 1 dB/cm attenuation. The registration and the probe
// calibration are given exactly by loopOptions (the test plays those steps): figures are of the loop.
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "mrsns/io/statismo_io.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/workflow/navigation.h"
#include "test_data.h"
#include "translating_vessel.h"

namespace mrsns::test {

/// One SD of the vessel model's mode moves the whole vessel this far along x.
constexpr double kVesselSdMm = 5.0;
inline const Eigen::Vector3d kModelInCt(-20.0, -25.0, -15.0);

/// The image plane across the vessel (model z) at model height z, the vessel 12 mm deep, 32 mm wide: CT frame.
inline nlohmann::json imagePoseInCt(double z) {
  const Eigen::Vector3d o = kModelInCt + Eigen::Vector3d(-16.0, -12.0, z);
  return {{"matrix", {1, 0, 0, o.x(), 0, 1, 0, o.y(), 0, 0, 1, o.z(), 0, 0, 0, 1}}};
}

struct VesselMotion {
  double amplitude_sd = 1.0;  ///< the seeded sinusoid's amplitude
  double period_s = 10.0;     ///< times a seeded factor in [0.7, 1.3]
  double push_sd = 0.0;       ///< a push along +x (SD), ramped in from push_start_s over push_ramp_s
  double push_start_s = 0.0;
  double push_ramp_s = 1.0;
};

struct LiveRoom {
  std::filesystem::path dir;
  simulation::Scenario scenario;
  std::unique_ptr<simulation::OperatingRoom> room;
};

inline LiveRoom startLiveRoom(const std::string& name, std::uint64_t seed, const VesselMotion& motion = {}) {
  using Json = nlohmann::json;
  LiveRoom r;
  r.dir = scratchDirectory(name);
  io::writeStatismoModel(translatingVessel(kVesselSdMm), r.dir / "vessel.h5");
  Json tissue = {{"shape_model", "vessel.h5"},
                 {"model_to_ct", {{"translation_mm", {kModelInCt.x(), kModelInCt.y(), kModelInCt.z()}}}},
                 {"modes", 1},
                 {"amplitude_sd", motion.amplitude_sd},
                 {"period_s", motion.period_s}};
  if (motion.push_sd != 0.0) {
    tissue["push"] = {{"start_s", motion.push_start_s}, {"ramp_s", motion.push_ramp_s}, {"sd", {motion.push_sd}}};
  }
  const Json s = {
      {"format", "mrsns-scenario/1"},
      {"seed", seed},
      {"duration_s", 0.0},
      {"tracker", {{"port", 0}, {"rate_hz", 60}}},
      {"tools",
       {{{"name", "PatientToTracker"}, {"start", {{"translation_mm", {0, 0, -1400}}}}},
        {{"name", "ProbeToTracker"},
         {"hand", {{"tremor_rms_mm", 0.3}, {"tremor_hz", {8.0, 12.0}}}},
         {"motion",
          {{{"kind", "hold"}, {"frame", "CT"}, {"pose_of", "image"}, {"pose", imagePoseInCt(-25.0)}, {"duration_s", 0.5}},
           {{"kind", "sweep"},
            {"frame", "CT"},
            {"pose_of", "image"},
            {"pose", imagePoseInCt(-6.0)},
            {"cycles", 20},
            {"duration_s", 60.0}}}}}}},
      {"patient",
       {{"generated_phantom", {{"spacing_mm", 2.0}}},
        {"reference_tool", "PatientToTracker"},
        {"ct_to_reference", {{"translation_mm", {0.0, 90.0, -30.0}}, {"rotation_deg", {90.0, 0.0, 0.0}}}},
        {"soft_tissue", tissue}}},
      {"ultrasound",
       {{"enabled", true},
        {"rate_hz", 20.0},
        {"width", 320},
        {"height", 320},
        {"spacing_mm", {0.1, 0.1}},
        {"probe_tool", "ProbeToTracker"},
        {"image_to_probe", {{"translation_mm", {-16.0, 5.0, 0.0}}}},
        {"video_lag_s", 0.0}}}};
  r.scenario = simulation::parseScenario(s.dump(), r.dir);
  r.room = std::make_unique<simulation::OperatingRoom>(r.scenario);
  r.room->start();
  return r;
}

/// The loop on the room's PlusServer, the soft tissue on, the registration and calibration exact.
inline workflow::NavigationOptions liveLoopOptions(const LiveRoom& r) {
  workflow::NavigationOptions o;
  o.devices.source = "plus";
  o.devices.port = r.room->endpoints().plus_port;
  o.required_transforms.clear();
  auto& st = o.soft_tissue;
  st.shape_model = r.dir / "vessel.h5";
  st.ct_T_model = r.scenario.patient->soft_tissue->ct_T_model;
  st.patient_T_ct = r.scenario.patient->reference_T_ct;
  const auto& us = r.scenario.ultrasound;
  st.probe_T_pixel = us.probe_T_image.matrix();
  st.probe_T_pixel.col(0) *= us.spacing_x_mm;
  st.probe_T_pixel.col(1) *= us.spacing_y_mm;
  st.image_width = us.width;
  st.image_height = us.height;
  return o;
}

}  // namespace mrsns::test
