#include "mrsns/igtlink/framer.h"

#include <algorithm>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/crc64.h"

namespace mrsns::igtlink {

void MessageFramer::reset() {
  buffer_.clear();
  start_ = 0;
  pending_.reset();
  failed_ = false;
}

void MessageFramer::checkPendingHeader() {
  if (failed_) {
    throw FormatError(
        "OpenIGTLink stream: an earlier header was invalid, so message boundaries are lost; reset() "
        "the framer and reconnect");
  }
  if (pending_ || bufferedBytes() < kHeaderSize) return;
  try {
    Header h = decodeHeader(std::span<const std::uint8_t>(buffer_).subspan(start_, kHeaderSize));
    const std::uint64_t limit =
        body_limit_ ? std::min(options_.max_body_size, body_limit_(h)) : options_.max_body_size;
    if (h.body_size > limit) {
      throw FormatError("OpenIGTLink header (" + h.type + " from '" + h.device_name + "'): field 'body_size' is " +
                        std::to_string(h.body_size) + " bytes, over the limit of " + std::to_string(limit));
    }
    pending_ = std::move(h);
  } catch (const FormatError&) {
    failed_ = true;
    throw;
  }
}

void MessageFramer::push(std::span<const std::uint8_t> chunk) {
  checkPendingHeader();
  if (start_ > 0 && start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  } else if (start_ >= (1u << 16) && start_ * 2 >= buffer_.size()) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    start_ = 0;
  }
  buffer_.insert(buffer_.end(), chunk.begin(), chunk.end());
  checkPendingHeader();
}

std::optional<Frame> MessageFramer::nextFrame() {
  checkPendingHeader();
  if (!pending_ || bufferedBytes() - kHeaderSize < pending_->body_size) return std::nullopt;
  Frame frame;
  frame.header = std::move(*pending_);
  pending_.reset();
  const auto body_begin = buffer_.begin() + static_cast<std::ptrdiff_t>(start_ + kHeaderSize);
  frame.body.assign(body_begin, body_begin + static_cast<std::ptrdiff_t>(frame.header.body_size));
  start_ += kHeaderSize + static_cast<std::size_t>(frame.header.body_size);
  if (options_.verify_crc && crc64(frame.body) != frame.header.crc) {
    throw FormatError("OpenIGTLink " + frame.header.type + " message from '" + frame.header.device_name +
                      "': field 'crc' does not match the body (message dropped)");
  }
  return frame;
}

std::optional<Message> MessageFramer::next() {
  auto frame = nextFrame();
  if (!frame) return std::nullopt;
  DecodeOptions options = options_;
  options.verify_crc = false;  // checked by nextFrame
  return decodeBody(frame->header, frame->body, options);
}

}  // namespace mrsns::igtlink
