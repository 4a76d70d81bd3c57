#pragma once
// STATUS content: code, sub-code, error name and a status text.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace mrsns::igtlink {

/// Status codes defined by the protocol.
enum class StatusCode : std::uint16_t {
  kInvalid = 0,
  kOk = 1,
  kUnknownError = 2,
  kPanic = 3,
  kNotFound = 4,
  kAccessDenied = 5,
  kBusy = 6,
  kTimeOut = 7,
  kOverflow = 8,
  kChecksumError = 9,
  kConfigError = 10,
  kResourceError = 11,
  kUnknownInstruction = 12,
  kNotReady = 13,
  kManualMode = 14,
  kDisabled = 15,
  kNotPresent = 16,
  kUnknownVersion = 17,
  kHardwareFailure = 18,
  kShutdown = 19,
};

/// STATUS: 30 fixed bytes then the NUL-terminated status text.
struct StatusContent {
  std::uint16_t code = static_cast<std::uint16_t>(StatusCode::kOk);
  std::int64_t subcode = 0;
  std::string error_name;  ///< at most 20 characters
  std::string message;
};

inline constexpr std::size_t kStatusFixedSize = 30;

void encodeStatus(const StatusContent& content, std::vector<std::uint8_t>& out);
StatusContent decodeStatus(std::span<const std::uint8_t> content);

}  // namespace mrsns::igtlink
