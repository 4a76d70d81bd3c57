#pragma once
// Runs `mrsns-cli serve ...` in the background (the test talks to it over
// loopback meanwhile), then stops it with SIGTERM or waits for it.
#include <string>
#include <vector>

#include "background_process.h"
#include "cli_runner.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::test {

/// A free loopback port for a server another process is told about before it starts: below the system's
/// ephemeral range, so no server bound to port 0 and no client's own end takes it meanwhile.
inline std::uint16_t freePort() {
  return igtlink::freeLocalPort("127.0.0.1");
}

/// `mrsns-cli serve ARGS...` in the background.
class ServeProcess : public BackgroundProcess {
 public:
  explicit ServeProcess(const std::vector<std::string>& args) : BackgroundProcess(argv(args)) {}

 private:
  static std::vector<std::string> argv(const std::vector<std::string>& args) {
    std::vector<std::string> v = {cliBinary().string(), "serve"};
    v.insert(v.end(), args.begin(), args.end());
    return v;
  }
};

}  // namespace mrsns::test
