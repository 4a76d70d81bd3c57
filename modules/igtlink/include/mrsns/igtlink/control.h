#pragma once
// Query and streaming-control messages shared by every data type (GET_xxx,
// STT_xxx, STP_xxx, RTS_xxx), and raw content for types this codec does not
// interpret (kept byte for byte so a relay can pass them on).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace mrsns::igtlink {

/// GET_xxx: a request for one message of type xxx; empty body.
struct GetRequest {};

/// STT_xxx: start streaming, optionally with the minimum interval between
/// messages (8 bytes, same 32.32 format as timestamps). STT_TDATA has its own
/// content (tdata.h).
struct StartStream {
  std::optional<std::uint64_t> resolution;
};

/// STP_xxx: stop streaming; empty body.
struct StopStream {};

/// RTS_xxx with a one-byte status (0 = success, 1 = error).
struct RtsStatus {
  std::uint8_t status = 0;
};

/// The content of any other type, or of a prefixed type whose body does not
/// have the generic shape above.
struct RawContent {
  std::vector<std::uint8_t> bytes;
};

}  // namespace mrsns::igtlink
