#pragma once
// The head of an HTTP/1.1 request, as much as the WebXR server reads: the
// request line and the headers (names lower-cased). The caller limits the
// head's size before it gets here.
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace mrsns::webxr {

struct HttpRequest {
  std::string method;
  std::string path;  ///< the target without its query string
  std::string query;
  std::map<std::string, std::string> headers;
  [[nodiscard]] std::optional<std::string> header(const std::string& lower_case_name) const {
    const auto it = headers.find(lower_case_name);
    return it == headers.end() ? std::nullopt : std::optional(it->second);
  }
};

/// Parses a request head ending in an empty line. Throws FormatError for a
/// malformed request line or header, a target that is not an absolute path
/// ("/..."), or one with "..", a NUL or a backslash.
HttpRequest parseHttpRequestHead(std::string_view head);

}  // namespace mrsns::webxr
