// The step table and the dispatch of runStep().
#include "mrsns/workflow/steps.h"

#include "mrsns/core/error.h"

namespace mrsns::workflow {

std::vector<StepInfo> listSteps() {
  return {
      {"connect-devices", "Connect devices", "preparation",
       "Tracker (simulated, PlusServer over OpenIGTLink, or playback of a PLUS recording): tools seen, rate, jitter"},
      {"us-spatial-calibration", "Ultrasound spatial calibration", "preparation",
       "N-wire calibration of ImageToProbe on a tracked recording (PLUS fCal data by default)"},
      {"us-temporal-calibration", "Ultrasound temporal calibration", "preparation",
       "Tracker lag behind the video from a probe moving over a line target"},
      {"robot-calibration", "Robot calibration", "preparation", "RobotBase to tracker (hand-eye) calibration"},
      {"registration", "Patient registration", "preparation",
       "Landmarks then surface (ICP) registration of the CT models to the patient"},
      {"hmd-calibration", "HMD calibration", "preparation",
       "Hologram to tracker calibration of the head-mounted display"},
      {"navigation", "Navigation", "function",
       "Tracking -> repository -> deformation -> supervisor -> hologram stream, recorded"},
      {"robot-placement", "Robot-assisted placement", "function",
       "Robot-guided pedicle screw placement on the planned paths"},
  };
}

std::filesystem::path sampleSessionPath();
}  // namespace mrsns::workflow
