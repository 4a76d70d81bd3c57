#include "mrsns/core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include <mutex>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns {

std::shared_ptr<spdlog::logger> logger() {
  static std::once_flag once;
  static std::shared_ptr<spdlog::logger> instance;
  std::call_once(once, [] {
    instance = spdlog::get("mrsns");
    if (!instance) {
      instance = spdlog::stderr_color_mt("mrsns");
      instance->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
      instance->set_level(spdlog::level::info);
    }
  });
  return instance;
}

void setLogLevel(std::string_view level) {
  const auto parsed = spdlog::level::from_str(std::string(level));
  if (parsed == spdlog::level::off && level != "off") {
    throw InvalidArgumentError("unknown log level '" + std::string(level) +
                               "': use trace, debug, info, warn, error, critical or off");
  }
  logger()->set_level(parsed);
}

}  // namespace mrsns
