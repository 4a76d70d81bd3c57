// The ultrasound verbs (calibrate-us, calibrate-temporal, register-phantom,
// reconstruct-volume),
// registered together so main() needs one line.
#include "cli_context.h"

namespace mrsns::cli {

void registerCalibrateUsVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerCalibrateTemporalVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerRegisterPhantomVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);
void registerReconstructVolumeVerb(CLI::App& app, GlobalOptions& options, VerbList& verbs);

void registerUltrasoundVerbs(CLI::App& app, GlobalOptions& options, VerbList& verbs) {
  registerCalibrateUsVerb(app, options, verbs);
  registerCalibrateTemporalVerb(app, options, verbs);
  registerRegisterPhantomVerb(app, options, verbs);
  registerReconstructVolumeVerb(app, options, verbs);
}

}  // namespace mrsns::cli
