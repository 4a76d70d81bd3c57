// libFuzzer target: the OpenIGTLink decoder (header v1/v2, metadata, every
// typed content) and the stream framer. Any input must either decode or throw
// an mrsns::Error (NDARRAY bodies too), never read out of bounds or allocate what a size field
// merely claims; a decoded message must re-encode, and decode(encode(m))
// must encode to the same bytes again.
#include <cstdint>
#include <cstdlib>
#include <span>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/codec.h"
#include "mrsns/igtlink/framer.h"
#include "mrsns/igtlink/ndarray.h"

namespace {

using namespace mrsns::igtlink;

DecodeOptions fuzzOptions() {
  DecodeOptions options;
  options.max_body_size = 1 << 20;
  options.verify_crc = false;  // let mutations reach the content decoders
  return options;
}

void checkReencoding(const Message& m) {
  // NDARRAY (the hologram stream's vertex updates) travels as raw content: its own decoder, and its round trip.
  if (const auto* raw = m.as<RawContent>(); raw && m.header.type == "NDARRAY") {
    try {
      const NdArrayFloat32 array = decodeNdArray(raw->bytes);
      if (encodeNdArray(array) != raw->bytes) std::abort();
    } catch (const mrsns::Error&) {
    }
  }
  const auto version = static_cast<HeaderVersion>(m.header.version);
  const auto first = encodeMessage(m, version);
  const Message again = decodeMessage(first, fuzzOptions());
  if (encodeMessage(again, version) != first) std::abort();  // decode/encode disagree
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::span<const std::uint8_t> bytes(data, size);
  try {
    checkReencoding(decodeMessage(bytes, fuzzOptions()));
  } catch (const mrsns::Error&) {
  }
  // The same bytes as a stream, in uneven chunks.
  MessageFramer framer(fuzzOptions());
  try {
    std::size_t at = 0;
    std::size_t chunk = 1;
    while (at < size) {
      const std::size_t n = std::min(chunk, size - at);
      framer.push(bytes.subspan(at, n));
      at += n;
      chunk = chunk * 3 + 1;
      for (;;) {
        try {
          auto m = framer.next();
          if (!m) break;
          checkReencoding(*m);
        } catch (const mrsns::FormatError&) {
          if (framer.failed()) throw;
        }
      }
    }
  } catch (const mrsns::Error&) {
  }
  return 0;
}
