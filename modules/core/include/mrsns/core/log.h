#pragma once
// The one logging facility of MR-SNS (spdlog). Modules log through
// mrsns::logger(); nothing outside app/cli writes to stdout.
#include <spdlog/spdlog.h>

#include <memory>
#include <string_view>

namespace mrsns {

/// The shared logger ("mrsns"); writes to stderr so stdout stays clean for
/// the CLI's JSON output.
std::shared_ptr<spdlog::logger> logger();

/// Sets the level from a name: trace, debug, info, warn, error, critical, off.
/// Throws InvalidArgumentError for an unknown name.
void setLogLevel(std::string_view level);

}  // namespace mrsns
