#pragma once
// The wall clock as the devices stamp their messages: seconds since the Unix
// epoch (UTC), as OpenIGTLink and PLUS sequence files carry them.
#include <chrono>

namespace mrsns {

inline double unixTimeSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace mrsns
