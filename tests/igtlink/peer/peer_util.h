#pragma once
// Helpers to drive Debian's libopenigtlink 1.11 (header v1 only) as a test peer.
#include <igtlMessageBase.h>
#include <igtlMessageHeader.h>
#include <igtl_header.h>

#include <cstdint>
#include <cstring>
#include <vector>

namespace mrsns::igtlink::peer {

/// Bytes as the peer packs them.
inline std::vector<std::uint8_t> packedBytes(igtl::MessageBase* message) {
  message->Pack();
  const auto* p = static_cast<const std::uint8_t*>(message->GetPackPointer());
  return std::vector<std::uint8_t>(p, p + message->GetPackSize());
}

/// Lets the peer decode `bytes` as message type T, the way a receiving
/// application does (header first, then the body). `status` receives the
/// Unpack flags (igtl::MessageHeader::UNPACK_BODY when the body was accepted).
template <typename T>
typename T::Pointer peerDecode(const std::vector<std::uint8_t>& bytes, int& status, int crc_check = 1) {
  auto header = igtl::MessageHeader::New();
  header->InitPack();
  std::memcpy(header->GetPackPointer(), bytes.data(), IGTL_HEADER_SIZE);
  header->Unpack();
  auto message = T::New();
  message->SetMessageHeader(header);
  message->AllocatePack();
  std::memcpy(message->GetPackBodyPointer(), bytes.data() + IGTL_HEADER_SIZE,
              static_cast<std::size_t>(message->GetPackBodySize()));
  status = message->Unpack(crc_check);
  return message;
}

}  // namespace mrsns::igtlink::peer
