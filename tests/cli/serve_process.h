#pragma once
// Runs `mrsns-cli serve ...` in the background (the test talks to it over
// loopback meanwhile), then stops it with SIGTERM or waits for it.
#include <string>
#include <vector>

#include "background_process.h"
#include "cli_runner.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::test {

/// A free loopback port (bound once by a throw-away server, then released).
inline std::uint16_t freePort() {
  igtlink::ServerOptions options;
  options.port = 0;
  igtlink::Server server(options);
  server.start();
  const auto port = server.port();
  server.stop();
  return port;
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
