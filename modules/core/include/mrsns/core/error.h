#pragma once
// Typed errors for invalid input at an API boundary. Each carries a message a
// user can act on: what was wrong, where, and what to do about it.
#include <stdexcept>
#include <string>

namespace mrsns {

/// Base of every error MR-SNS throws on purpose. The GUI and the CLI catch it
/// at their boundary and show what().
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// A caller passed an argument that cannot be used (wrong size, NaN, empty).
class InvalidArgumentError : public Error {
 public:
  using Error::Error;
};

/// A file could not be opened, read or written (missing, permissions, disk).
class FileError : public Error {
 public:
  using Error::Error;
};

/// A file or message was read but its content is malformed, truncated or
/// inconsistent with itself.
class FormatError : public Error {
 public:
  using Error::Error;
};

/// A file or message is well formed but uses a feature MR-SNS does not support.
class UnsupportedError : public Error {
 public:
  using Error::Error;
};

/// A coordinate frame or transform cannot be resolved (unknown frame,
/// disconnected graph, contradictory edges).
class FrameError : public Error {
 public:
  using Error::Error;
};

/// A computation was refused or failed because the input is degenerate
/// (collinear points, too little motion, singular system).
class ComputationError : public Error {
 public:
  using Error::Error;
};

/// A network peer misbehaved or could not be reached.
class NetworkError : public Error {
 public:
  using Error::Error;
};

}  // namespace mrsns
