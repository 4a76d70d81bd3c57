#pragma once
// RTDE (Real-Time Data Exchange, TCP port 30004) protocol version 2 as documented by Universal Robots: the
// codec only, pure bytes, no sockets. A package is a big-endian header (uint16 size including the header,
// uint8 type) and a payload whose layout depends on the type. Data packages carry the fields of a recipe
// negotiated beforehand with CONTROL_PACKAGE_SETUP_OUTPUTS / _INPUTS; the recipe is not on the wire, so the
// decoder needs it. Malformed or truncated bytes throw FormatError naming the field; nothing reads out of bounds.
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace mrsns::robot::rtde {

constexpr std::uint16_t kProtocolVersion = 2;
constexpr std::size_t kHeaderSize = 3;
constexpr std::uint16_t kDefaultPort = 30004;

enum class PackageType : std::uint8_t {
  RequestProtocolVersion = 'V',  // 86
  GetUrControlVersion = 'v',     // 118
  TextMessage = 'M',             // 77
  DataPackage = 'U',             // 85
  SetupOutputs = 'O',            // 79
  SetupInputs = 'I',             // 73
  Start = 'S',                   // 83
  Pause = 'P',                   // 80
};
const char* toString(PackageType type);

enum class FieldType { Bool, Uint8, Uint32, Uint64, Int32, Double, Vector3d, Vector6d, Vector6Int32, Vector6Uint32 };
/// The RTDE spelling: "BOOL", "UINT8", ..., "VECTOR6UINT32".
const char* toString(FieldType type);
/// Parses the RTDE spelling; throws FormatError for anything else ("NOT_FOUND", "IN_USE", typos).
FieldType fieldTypeFromString(std::string_view name);
/// Bytes the field occupies in a data package.
std::size_t fieldSize(FieldType type);

using Value =
    std::variant<bool, std::uint8_t, std::uint32_t, std::uint64_t, std::int32_t, double, std::array<double, 3>,
                 std::array<double, 6>, std::array<std::int32_t, 6>, std::array<std::uint32_t, 6>>;
/// The type a value holds (index of the variant maps 1:1 onto FieldType).
FieldType typeOf(const Value& value);
/// A zero value of the given type.
Value zeroValue(FieldType type);

/// The type the controller uses for a variable name (inputs, outputs, registers), or nullopt when unknown.
std::optional<FieldType> variableType(std::string_view name);

struct Field {
  std::string name;
  FieldType type = FieldType::Double;
};

struct Recipe {
  std::uint8_t id = 0;  // assigned by the controller in the setup reply; 0 before
  std::vector<Field> fields;

  [[nodiscard]] std::size_t payloadSize() const;  // bytes of the field values (without recipe id)
  /// Index of a field by name, or -1.
  [[nodiscard]] int indexOf(std::string_view name) const;
  [[nodiscard]] std::vector<std::string> names() const;
};

/// A recipe from variable names, typed with variableType(); throws FormatError naming an unknown variable.
Recipe recipeFromNames(const std::vector<std::string>& names);
/// Parses a recipe text file's content (one variable per line, as the official clients' *_recipe.txt; blank
/// lines and '#' comments ignored). `source` names the file in errors.
Recipe parseRecipeText(std::string_view text, std::string_view source);
/// Parses the official Python client's XML configuration content (<rtde_config><recipe key="..."><field
/// name="..." type="..."/>), comments excluded. Returns (key, recipe) pairs in file order.
std::vector<std::pair<std::string, Recipe>> parseRecipeXml(std::string_view xml, std::string_view source);

struct Package {
  PackageType type = PackageType::TextMessage;
  std::vector<std::uint8_t> payload;
};

/// Header + payload. Throws InvalidArgumentError when the payload exceeds 65532 bytes.
std::vector<std::uint8_t> encodePackage(PackageType type, std::span<const std::uint8_t> payload);
/// Exactly one package (size field == bytes.size()); throws FormatError otherwise or on an unknown type.
Package decodePackage(std::span<const std::uint8_t> bytes);

/// Splits a TCP byte stream into packages. push() appends bytes; next() returns the next complete package or
/// nullopt; throws FormatError (and stays failed) on a size below the header or an unknown type.
class PackageFramer {
 public:
  void push(std::span<const std::uint8_t> bytes);
  std::optional<Package> next();
  [[nodiscard]] std::size_t bufferedBytes() const { return buffer_.size() - start_; }

 private:
  std::vector<std::uint8_t> buffer_;
  std::size_t start_ = 0;
};

// --- client -> controller -------------------------------------------------------------------------------------
std::vector<std::uint8_t> encodeRequestProtocolVersion(std::uint16_t version = kProtocolVersion);
std::vector<std::uint8_t> encodeGetUrControlVersion();
/// frequency_hz: 1..500 (e-series) / 125 (CB3); names comma-joined on the wire.
std::vector<std::uint8_t> encodeSetupOutputs(double frequency_hz, const std::vector<std::string>& names);
std::vector<std::uint8_t> encodeSetupInputs(const std::vector<std::string>& names);
std::vector<std::uint8_t> encodeStart();
std::vector<std::uint8_t> encodePause();

struct SetupOutputsRequest {
  double frequency_hz = 0;
  std::vector<std::string> names;
};
std::uint16_t decodeRequestProtocolVersion(const Package& package);
SetupOutputsRequest decodeSetupOutputsRequest(const Package& package);
std::vector<std::string> decodeSetupInputsRequest(const Package& package);

// --- controller -> client -------------------------------------------------------------------------------------
/// Reply to 'V', 'S' and 'P': one uint8, 1 = accepted.
std::vector<std::uint8_t> encodeAccepted(PackageType type, bool accepted);
bool decodeAccepted(const Package& package, PackageType expected);

struct UrControlVersion {
  std::uint32_t major = 0, minor = 0, bugfix = 0, build = 0;
};
std::vector<std::uint8_t> encodeUrControlVersion(const UrControlVersion& version);
UrControlVersion decodeUrControlVersion(const Package& package);

/// Reply to a setup request: the recipe id and, per requested variable, its type or "NOT_FOUND" / "IN_USE".
struct SetupReply {
  std::uint8_t recipe_id = 0;
  std::vector<std::string> types;
};
std::vector<std::uint8_t> encodeSetupReply(PackageType type, const SetupReply& reply);
SetupReply decodeSetupReply(const Package& package, PackageType expected);
/// Recipe of a reply for the requested names; throws FormatError naming every variable the controller did not
/// accept (NOT_FOUND, IN_USE) or a count mismatch.
Recipe recipeFromReply(const std::vector<std::string>& requested, const SetupReply& reply);

enum class MessageLevel : std::uint8_t { Exception = 0, Error = 1, Warning = 2, Info = 3 };
struct TextMessage {
  std::string message;
  std::string source;
  MessageLevel level = MessageLevel::Info;
};
std::vector<std::uint8_t> encodeTextMessage(const TextMessage& message);
TextMessage decodeTextMessage(const Package& package);

/// A data package: recipe id and the values in recipe order. Types are checked against the recipe.
std::vector<std::uint8_t> encodeDataPackage(const Recipe& recipe, std::span<const Value> values);
/// Throws FormatError when the recipe id differs or the payload size does not match the recipe exactly.
std::vector<Value> decodeDataPackage(const Package& package, const Recipe& recipe);

}  // namespace mrsns::robot::rtde
