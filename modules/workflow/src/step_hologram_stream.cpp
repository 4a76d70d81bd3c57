#include "step_hologram_stream.h"

namespace mrsns::workflow::detail {

StepStreamAddress stepStreamAddress(const std::string& step, const Params& p, std::uint64_t max_body_bytes) {
  const int port = p.integer("hmd_port", 18945);
  if (port < 1 || port > 65535) throw InvalidArgumentError(step + ": hmd_port must be 1-65535");
  StepStreamAddress a;
  a.server.bind_address = p.text("hmd_address", "127.0.0.1");
  a.server.port = static_cast<std::uint16_t>(port);
  a.server.max_clients = 4;
  a.server.decode.max_body_size = max_body_bytes;
  a.endpoint = a.server.bind_address + ":" + std::to_string(port);
  a.unity = p.boolean("unity", false);
  return a;
}

namespace {

tracking::HologramStreamOptions withConvention(tracking::HologramStreamOptions options, bool unity) {
  options.unity = unity;
  return options;
}

}  // namespace

StepHologramStream::StepHologramStream(const std::string& step, const StepStreamAddress& address,
                                       std::shared_ptr<TransformRepository> repository,
                                       std::vector<tracking::HologramModel> models,
                                       tracking::HologramStreamOptions options)
    : server_(address.server),
      streamer_(server_, std::move(repository), std::move(models), withConvention(std::move(options), address.unity)) {
  try {
    server_.start();
  } catch (const Error& e) {
    throw NetworkError(step + ": cannot serve the hologram stream on " + address.endpoint + " (" + e.what() +
                       "): another hologram stream (the GUI's, mrsns-cli serve) may hold that port; stop it or "
                       "choose hmd_port");
  }
}

}  // namespace mrsns::workflow::detail
