#include "http_request.h"

#include <algorithm>
#include <cctype>

#include "mrsns/core/error.h"

namespace mrsns::webxr {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

}  // namespace

HttpRequest parseHttpRequestHead(std::string_view head) {
  HttpRequest request;
  std::size_t line_end = head.find("\r\n");
  if (line_end == std::string_view::npos) throw FormatError("HTTP request without a request line");
  const std::string_view line = head.substr(0, line_end);
  const auto first_space = line.find(' ');
  const auto last_space = line.rfind(' ');
  if (first_space == std::string_view::npos || first_space == last_space) throw FormatError("malformed request line");
  request.method = std::string(line.substr(0, first_space));
  std::string_view target = line.substr(first_space + 1, last_space - first_space - 1);
  if (!line.substr(last_space + 1).starts_with("HTTP/1.")) throw FormatError("not an HTTP/1.x request");
  if (target.empty() || target.front() != '/') throw FormatError("the target is not an absolute path");
  if (const auto q = target.find('?'); q != std::string_view::npos) {
    request.query = std::string(target.substr(q + 1));
    target = target.substr(0, q);
  }
  if (target.find("..") != std::string_view::npos || target.find('\\') != std::string_view::npos ||
      target.find('\0') != std::string_view::npos) {
    throw FormatError("the target leaves the served folder");
  }
  request.path = std::string(target);

  std::size_t at = line_end + 2;
  while (at < head.size()) {
    line_end = head.find("\r\n", at);
    if (line_end == std::string_view::npos) line_end = head.size();
    const std::string_view header = head.substr(at, line_end - at);
    at = line_end + 2;
    if (header.empty()) break;
    const auto colon = header.find(':');
    if (colon == std::string_view::npos || colon == 0) throw FormatError("malformed header line");
    std::string name(trim(header.substr(0, colon)));
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    request.headers[name] = std::string(trim(header.substr(colon + 1)));
  }
  return request;
}

}  // namespace mrsns::webxr
