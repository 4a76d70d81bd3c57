#include "mrsns/robot/rtde_protocol.h"

#include <algorithm>
#include <charconv>
#include <unordered_map>

#include "mrsns/core/error.h"
#include "ur_bytes.h"

namespace mrsns::robot::rtde {
namespace {

using detail::BeReader;
using detail::BeWriter;

bool knownType(std::uint8_t t) {
  switch (static_cast<PackageType>(t)) {
    case PackageType::RequestProtocolVersion:
    case PackageType::GetUrControlVersion:
    case PackageType::TextMessage:
    case PackageType::DataPackage:
    case PackageType::SetupOutputs:
    case PackageType::SetupInputs:
    case PackageType::Start:
    case PackageType::Pause: return true;
  }
  return false;
}

std::string typeName(std::uint8_t t) {
  std::string s = std::to_string(t);
  if (t >= 32 && t < 127) s += std::string(" '") + static_cast<char>(t) + "'";
  return s;
}

void expectType(const Package& package, PackageType expected) {
  if (package.type != expected) {
    throw FormatError(std::string("RTDE: expected a ") + toString(expected) + " package but received " +
                      toString(package.type) + " (protocol out of step: reconnect)");
  }
}

void expectEnd(const BeReader& reader, PackageType type) {
  if (!reader.atEnd()) {
    throw FormatError(std::string("RTDE ") + toString(type) + ": " + std::to_string(reader.remaining()) +
                      " unexpected trailing bytes (package size field inconsistent with its content)");
  }
}

std::vector<std::string> splitComma(std::string_view s) {
  std::vector<std::string> out;
  if (s.empty()) return out;
  std::size_t start = 0;
  for (;;) {
    const auto comma = s.find(',', start);
    out.emplace_back(s.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

std::string joinComma(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) {
    if (n.empty() || n.find(',') != std::string::npos) {
      throw InvalidArgumentError("RTDE recipe: variable name '" + n +
                                 "' is empty or contains a comma; pass one variable name per entry");
    }
    if (!out.empty()) out += ',';
    out += n;
  }
  return out;
}

const std::unordered_map<std::string_view, FieldType>& namedTypes() {
  using enum FieldType;
  static const std::unordered_map<std::string_view, FieldType> table{
      // inputs
      {"speed_slider_mask", Uint32},
      {"speed_slider_fraction", Double},
      {"standard_digital_output_mask", Uint8},
      {"standard_digital_output", Uint8},
      {"configurable_digital_output_mask", Uint8},
      {"configurable_digital_output", Uint8},
      {"tool_digital_output_mask", Uint8},
      {"tool_digital_output", Uint8},
      {"standard_analog_output_mask", Uint8},
      {"standard_analog_output_type", Uint8},
      {"standard_analog_output_0", Double},
      {"standard_analog_output_1", Double},
      {"external_force_torque", Vector6d},
      {"input_bit_registers0_to_31", Uint32},
      {"input_bit_registers32_to_63", Uint32},
      // outputs
      {"timestamp", Double},
      {"target_q", Vector6d},
      {"target_qd", Vector6d},
      {"target_qdd", Vector6d},
      {"target_current", Vector6d},
      {"target_moment", Vector6d},
      {"actual_q", Vector6d},
      {"actual_qd", Vector6d},
      {"actual_current", Vector6d},
      {"actual_current_window", Vector6d},
      {"actual_current_as_torque", Vector6d},
      {"joint_control_output", Vector6d},
      {"actual_TCP_pose", Vector6d},
      {"actual_TCP_speed", Vector6d},
      {"actual_TCP_force", Vector6d},
      {"target_TCP_pose", Vector6d},
      {"target_TCP_speed", Vector6d},
      {"tcp_offset", Vector6d},
      {"actual_TCP_acceleration", Vector6d},
      {"target_TCP_acceleration", Vector6d},
      {"actual_digital_input_bits", Uint64},
      {"actual_configurable_digital_input_bits", Uint64},
      {"joint_temperatures", Vector6d},
      {"actual_execution_time", Double},
      {"target_execution_time", Double},
      {"robot_mode", Int32},
      {"joint_mode", Vector6Int32},
      {"safety_mode", Int32},
      {"safety_status", Int32},
      {"actual_tool_accelerometer", Vector3d},
      {"speed_scaling", Double},
      {"target_speed_fraction", Double},
      {"actual_momentum", Double},
      {"actual_main_voltage", Double},
      {"actual_robot_voltage", Double},
      {"actual_robot_current", Double},
      {"actual_joint_voltage", Vector6d},
      {"actual_digital_output_bits", Uint64},
      {"actual_configurable_digital_output_bits", Uint64},
      {"runtime_state", Uint32},
      {"elbow_position", Vector3d},
      {"elbow_velocity", Vector3d},
      {"robot_status_bits", Uint32},
      {"safety_status_bits", Uint32},
      {"analog_io_types", Uint32},
      {"standard_analog_input0", Double},
      {"standard_analog_input1", Double},
      {"standard_analog_output0", Double},
      {"standard_analog_output1", Double},
      {"io_current", Double},
      {"actual_robot_energy_consumed", Double},
      {"actual_robot_braking_energy_dissipated", Double},
      {"encoder0_raw", Int32},
      {"encoder1_raw", Int32},
      {"euromap67_input_bits", Uint32},
      {"euromap67_output_bits", Uint32},
      {"euromap67_24V_voltage", Double},
      {"euromap67_24V_current", Double},
      {"tool_mode", Uint32},
      {"tool_analog_input_types", Uint32},
      {"tool_analog_input0", Double},
      {"tool_analog_input1", Double},
      {"tool_output_voltage", Int32},
      {"tool_output_current", Double},
      {"tool_temperature", Double},
      {"tool_output_mode", Uint8},
      {"tool_digital_output0_mode", Uint8},
      {"tool_digital_output1_mode", Uint8},
      {"tcp_force_scalar", Double},
      {"joint_position_deviation_ratio", Double},
      {"collision_detection_ratio", Double},
      {"ft_raw_wrench", Vector6d},
      {"wrench_calc_from_currents", Vector6d},
      {"payload", Double},
      {"payload_cog", Vector3d},
      {"payload_inertia", Vector6d},
      {"script_control_line", Uint32},
      {"time_scale_source", Int32},
      {"target_gravity", Vector3d},
      {"target_base_acceleration", Vector6d},
      {"control_step", Uint64},
      {"target_base_wrench", Vector6d},
      {"output_bit_registers0_to_31", Uint32},
      {"output_bit_registers32_to_63", Uint32}};
  return table;
}

// "<prefix><n>" with n in [lo, hi].
bool registerIndex(std::string_view name, std::string_view prefix, int lo, int hi) {
  if (!name.starts_with(prefix)) return false;
  const auto digits = name.substr(prefix.size());
  if (digits.empty() || digits.size() > 3) return false;
  int n = -1;
  const auto [ptr, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), n);
  return ec == std::errc() && ptr == digits.data() + digits.size() && n >= lo && n <= hi &&
         (digits.size() == 1 || digits[0] != '0');
}

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(b, e - b + 1));
}

}  // namespace

const char* toString(PackageType type) {
  switch (type) {
    case PackageType::RequestProtocolVersion: return "RTDE_REQUEST_PROTOCOL_VERSION";
    case PackageType::GetUrControlVersion: return "RTDE_GET_URCONTROL_VERSION";
    case PackageType::TextMessage: return "RTDE_TEXT_MESSAGE";
    case PackageType::DataPackage: return "RTDE_DATA_PACKAGE";
    case PackageType::SetupOutputs: return "RTDE_CONTROL_PACKAGE_SETUP_OUTPUTS";
    case PackageType::SetupInputs: return "RTDE_CONTROL_PACKAGE_SETUP_INPUTS";
    case PackageType::Start: return "RTDE_CONTROL_PACKAGE_START";
    case PackageType::Pause: return "RTDE_CONTROL_PACKAGE_PAUSE";
  }
  return "RTDE_UNKNOWN";
}

const char* toString(FieldType type) {
  switch (type) {
    case FieldType::Bool: return "BOOL";
    case FieldType::Uint8: return "UINT8";
    case FieldType::Uint32: return "UINT32";
    case FieldType::Uint64: return "UINT64";
    case FieldType::Int32: return "INT32";
    case FieldType::Double: return "DOUBLE";
    case FieldType::Vector3d: return "VECTOR3D";
    case FieldType::Vector6d: return "VECTOR6D";
    case FieldType::Vector6Int32: return "VECTOR6INT32";
    case FieldType::Vector6Uint32: return "VECTOR6UINT32";
  }
  return "UNKNOWN";
}

FieldType fieldTypeFromString(std::string_view name) {
  for (int i = 0; i <= static_cast<int>(FieldType::Vector6Uint32); ++i) {
    if (name == toString(static_cast<FieldType>(i))) return static_cast<FieldType>(i);
  }
  throw FormatError("RTDE: unknown field type '" + std::string(name) +
                    "' (expected BOOL, UINT8, UINT32, UINT64, INT32, DOUBLE, VECTOR3D, VECTOR6D, VECTOR6INT32 or "
                    "VECTOR6UINT32)");
}

std::size_t fieldSize(FieldType type) {
  switch (type) {
    case FieldType::Bool:
    case FieldType::Uint8: return 1;
    case FieldType::Uint32:
    case FieldType::Int32: return 4;
    case FieldType::Uint64:
    case FieldType::Double: return 8;
    case FieldType::Vector3d: return 24;
    case FieldType::Vector6d: return 48;
    case FieldType::Vector6Int32:
    case FieldType::Vector6Uint32: return 24;
  }
  return 0;
}

FieldType typeOf(const Value& value) {
  return static_cast<FieldType>(value.index());
}

Value zeroValue(FieldType type) {
  switch (type) {
    case FieldType::Bool: return false;
    case FieldType::Uint8: return std::uint8_t{0};
    case FieldType::Uint32: return std::uint32_t{0};
    case FieldType::Uint64: return std::uint64_t{0};
    case FieldType::Int32: return std::int32_t{0};
    case FieldType::Double: return 0.0;
    case FieldType::Vector3d: return std::array<double, 3>{};
    case FieldType::Vector6d: return std::array<double, 6>{};
    case FieldType::Vector6Int32: return std::array<std::int32_t, 6>{};
    case FieldType::Vector6Uint32: return std::array<std::uint32_t, 6>{};
  }
  return 0.0;
}

std::optional<FieldType> variableType(std::string_view name) {
  const auto& table = namedTypes();
  if (const auto it = table.find(name); it != table.end()) return it->second;
  for (std::string_view io : {"input_", "output_"}) {
    if (!name.starts_with(io)) continue;
    const auto rest = name.substr(io.size());
    if (registerIndex(rest, "bit_register_", 64, 127)) return FieldType::Bool;
    if (registerIndex(rest, "int_register_", 0, 47)) return FieldType::Int32;
    if (registerIndex(rest, "double_register_", 0, 47)) return FieldType::Double;
  }
  return std::nullopt;
}

std::size_t Recipe::payloadSize() const {
  std::size_t n = 0;
  for (const auto& f : fields) n += fieldSize(f.type);
  return n;
}

int Recipe::indexOf(std::string_view name) const {
  for (std::size_t i = 0; i < fields.size(); ++i) {
    if (fields[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

std::vector<std::string> Recipe::names() const {
  std::vector<std::string> out;
  out.reserve(fields.size());
  for (const auto& f : fields) out.push_back(f.name);
  return out;
}

Recipe recipeFromNames(const std::vector<std::string>& names) {
  Recipe recipe;
  for (const auto& n : names) {
    const auto type = variableType(n);
    if (!type) {
      throw FormatError("RTDE recipe: unknown variable '" + n +
                        "' (not an RTDE input or output of the controller; check its spelling in the RTDE guide)");
    }
    recipe.fields.push_back({n, *type});
  }
  return recipe;
}

Recipe parseRecipeText(std::string_view text, std::string_view source) {
  std::vector<std::string> names;
  std::size_t start = 0;
  int line_no = 0;
  while (start <= text.size()) {
    const auto end = text.find('\n', start);
    const auto line = trim(text.substr(start, end == std::string_view::npos ? std::string_view::npos : end - start));
    ++line_no;
    if (!line.empty() && line[0] != '#') {
      if (!variableType(line)) {
        throw FormatError(std::string(source) + ":" + std::to_string(line_no) + ": unknown RTDE variable '" + line +
                          "' (one variable name per line expected)");
      }
      names.push_back(line);
    }
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
  if (names.empty()) throw FormatError(std::string(source) + ": the recipe lists no variables");
  return recipeFromNames(names);
}

std::vector<std::pair<std::string, Recipe>> parseRecipeXml(std::string_view xml_in, std::string_view source) {
  // Drop comments first: the official configurations keep optional fields in <!-- --> blocks.
  std::string xml;
  for (std::size_t pos = 0;;) {
    const auto open = xml_in.find("<!--", pos);
    xml.append(xml_in.substr(pos, open == std::string_view::npos ? std::string_view::npos : open - pos));
    if (open == std::string_view::npos) break;
    const auto close = xml_in.find("-->", open + 4);
    if (close == std::string_view::npos) {
      throw FormatError(std::string(source) + ": unterminated XML comment (missing '-->')");
    }
    pos = close + 3;
  }
  auto attribute = [&](std::string_view tag, std::string_view attr) -> std::string {
    const std::string key = std::string(attr) + "=\"";
    auto at = tag.find(" " + key);
    if (at == std::string_view::npos) at = tag.find("\t" + key);
    if (at == std::string_view::npos) {
      throw FormatError(std::string(source) + ": element <" + std::string(tag.substr(0, 40)) +
                        "...> lacks the attribute '" + std::string(attr) + "'");
    }
    const auto begin = at + 1 + key.size();
    const auto end = tag.find('"', begin);
    if (end == std::string_view::npos) throw FormatError(std::string(source) + ": unterminated attribute value");
    return std::string(tag.substr(begin, end - begin));
  };
  if (xml.find("<rtde_config") == std::string::npos) {
    throw FormatError(std::string(source) + ": not an RTDE configuration (no <rtde_config> element)");
  }
  std::vector<std::pair<std::string, Recipe>> out;
  for (std::size_t pos = 0;;) {
    const auto open = xml.find('<', pos);
    if (open == std::string::npos) break;
    const auto close = xml.find('>', open);
    if (close == std::string::npos) throw FormatError(std::string(source) + ": unterminated XML element");
    const std::string_view tag(xml.data() + open + 1, close - open - 1);
    pos = close + 1;
    if (tag.starts_with("recipe")) {
      out.emplace_back(attribute(tag, "key"), Recipe{});
    } else if (tag.starts_with("field")) {
      if (out.empty()) throw FormatError(std::string(source) + ": <field> outside a <recipe>");
      const auto name = attribute(tag, "name");
      const auto type = fieldTypeFromString(attribute(tag, "type"));
      out.back().second.fields.push_back({name, type});
    }
  }
  if (out.empty()) throw FormatError(std::string(source) + ": no <recipe> element");
  return out;
}

std::vector<std::uint8_t> encodePackage(PackageType type, std::span<const std::uint8_t> payload) {
  if (payload.size() + kHeaderSize > 0xFFFF) {
    throw InvalidArgumentError("RTDE: a " + std::string(toString(type)) + " payload of " +
                               std::to_string(payload.size()) + " bytes exceeds the 65532-byte package limit");
  }
  std::vector<std::uint8_t> out;
  out.reserve(payload.size() + kHeaderSize);
  const auto size = static_cast<std::uint16_t>(payload.size() + kHeaderSize);
  out.push_back(static_cast<std::uint8_t>(size >> 8));
  out.push_back(static_cast<std::uint8_t>(size & 0xFF));
  out.push_back(static_cast<std::uint8_t>(type));
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

Package decodePackage(std::span<const std::uint8_t> bytes) {
  BeReader reader(bytes, "RTDE package");
  const auto size = reader.u16("size");
  const auto type = reader.u8("type");
  if (size < kHeaderSize) {
    throw FormatError("RTDE package: size field " + std::to_string(size) + " is below the 3-byte header");
  }
  if (size != bytes.size()) {
    throw FormatError("RTDE package: size field says " + std::to_string(size) + " bytes but " +
                      std::to_string(bytes.size()) + " were given (truncated or concatenated packages)");
  }
  if (!knownType(type)) throw FormatError("RTDE package: unknown package type " + typeName(type));
  Package p;
  p.type = static_cast<PackageType>(type);
  p.payload.assign(bytes.begin() + kHeaderSize, bytes.end());
  return p;
}

void PackageFramer::push(std::span<const std::uint8_t> bytes) {
  if (start_ > 0 && start_ == buffer_.size()) {
    buffer_.clear();
    start_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
}

std::optional<Package> PackageFramer::next() {
  if (bufferedBytes() < kHeaderSize) return std::nullopt;
  const std::size_t size = (std::size_t{buffer_[start_]} << 8) | buffer_[start_ + 1];
  const auto type = buffer_[start_ + 2];
  if (size < kHeaderSize || !knownType(type)) {
    throw FormatError("RTDE stream: package of size " + std::to_string(size) + " and type " + typeName(type) +
                      " is not RTDE (wrong port, or the stream lost its framing): reconnect");
  }
  if (bufferedBytes() < size) return std::nullopt;
  Package p;
  p.type = static_cast<PackageType>(type);
  p.payload.assign(buffer_.begin() + static_cast<std::ptrdiff_t>(start_ + kHeaderSize),
                   buffer_.begin() + static_cast<std::ptrdiff_t>(start_ + size));
  start_ += size;
  if (start_ > 65536) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    start_ = 0;
  }
  return p;
}

std::vector<std::uint8_t> encodeRequestProtocolVersion(std::uint16_t version) {
  BeWriter w;
  w.u16(version);
  return encodePackage(PackageType::RequestProtocolVersion, w.bytes());
}

std::vector<std::uint8_t> encodeGetUrControlVersion() {
  return encodePackage(PackageType::GetUrControlVersion, {});
}

std::vector<std::uint8_t> encodeSetupOutputs(double frequency_hz, const std::vector<std::string>& names) {
  if (!(frequency_hz > 0 && frequency_hz <= 500)) {
    throw InvalidArgumentError("RTDE setup outputs: frequency " + std::to_string(frequency_hz) +
                               " Hz is outside (0, 500]; use 125 (CB3) or up to 500 (e-series)");
  }
  BeWriter w;
  w.f64(frequency_hz);
  w.string(joinComma(names));
  return encodePackage(PackageType::SetupOutputs, w.bytes());
}

std::vector<std::uint8_t> encodeSetupInputs(const std::vector<std::string>& names) {
  BeWriter w;
  w.string(joinComma(names));
  return encodePackage(PackageType::SetupInputs, w.bytes());
}

std::vector<std::uint8_t> encodeStart() {
  return encodePackage(PackageType::Start, {});
}
std::vector<std::uint8_t> encodePause() {
  return encodePackage(PackageType::Pause, {});
}

std::uint16_t decodeRequestProtocolVersion(const Package& package) {
  expectType(package, PackageType::RequestProtocolVersion);
  BeReader r(package.payload, "RTDE_REQUEST_PROTOCOL_VERSION");
  const auto v = r.u16("protocol_version");
  expectEnd(r, package.type);
  return v;
}

// The variable names of a setup request. One trailing comma is no empty variable: ur_rtde sends
// "timestamp,actual_q,...,output_double_register_19," and a real controller sets that recipe up.
std::vector<std::string> requestedNames(std::string_view text) {
  auto names = splitComma(text);
  if (names.size() > 1 && names.back().empty()) names.pop_back();
  return names;
}

SetupOutputsRequest decodeSetupOutputsRequest(const Package& package) {
  expectType(package, PackageType::SetupOutputs);
  BeReader r(package.payload, "RTDE_CONTROL_PACKAGE_SETUP_OUTPUTS request");
  SetupOutputsRequest out;
  out.frequency_hz = r.f64("output_frequency");
  out.names = requestedNames(r.rest());
  return out;
}

std::vector<std::string> decodeSetupInputsRequest(const Package& package) {
  expectType(package, PackageType::SetupInputs);
  return requestedNames(std::string(package.payload.begin(), package.payload.end()));
}

std::vector<std::uint8_t> encodeAccepted(PackageType type, bool accepted) {
  const std::uint8_t b = accepted ? 1 : 0;
  return encodePackage(type, std::span<const std::uint8_t>(&b, 1));
}

bool decodeAccepted(const Package& package, PackageType expected) {
  expectType(package, expected);
  BeReader r(package.payload, std::string(toString(expected)) + " reply");
  const auto v = r.u8("accepted");
  expectEnd(r, package.type);
  if (v > 1) throw FormatError(std::string(toString(expected)) + " reply: accepted byte is " + std::to_string(v));
  return v == 1;
}

std::vector<std::uint8_t> encodeUrControlVersion(const UrControlVersion& v) {
  BeWriter w;
  w.u32(v.major);
  w.u32(v.minor);
  w.u32(v.bugfix);
  w.u32(v.build);
  return encodePackage(PackageType::GetUrControlVersion, w.bytes());
}

UrControlVersion decodeUrControlVersion(const Package& package) {
  expectType(package, PackageType::GetUrControlVersion);
  BeReader r(package.payload, "RTDE_GET_URCONTROL_VERSION reply");
  UrControlVersion v;
  v.major = r.u32("major");
  v.minor = r.u32("minor");
  v.bugfix = r.u32("bugfix");
  v.build = r.u32("build");
  expectEnd(r, package.type);
  return v;
}

std::vector<std::uint8_t> encodeSetupReply(PackageType type, const SetupReply& reply) {
  BeWriter w;
  w.u8(reply.recipe_id);
  std::string types;
  for (const auto& t : reply.types) types += (types.empty() ? "" : ",") + t;
  w.string(types);
  return encodePackage(type, w.bytes());
}

SetupReply decodeSetupReply(const Package& package, PackageType expected) {
  expectType(package, expected);
  BeReader r(package.payload, std::string(toString(expected)) + " reply");
  SetupReply out;
  out.recipe_id = r.u8("output_recipe_id");
  out.types = splitComma(r.rest());
  return out;
}

Recipe recipeFromReply(const std::vector<std::string>& requested, const SetupReply& reply) {
  if (reply.types.size() != requested.size()) {
    throw FormatError("RTDE setup reply: " + std::to_string(reply.types.size()) + " types for " +
                      std::to_string(requested.size()) + " requested variables");
  }
  Recipe recipe;
  recipe.id = reply.recipe_id;
  std::string refused;
  for (std::size_t i = 0; i < requested.size(); ++i) {
    const auto& t = reply.types[i];
    if (t == "NOT_FOUND" || t == "IN_USE") {
      refused += (refused.empty() ? "" : ", ") + requested[i] + ":" + t;
      continue;
    }
    recipe.fields.push_back({requested[i], fieldTypeFromString(t)});
  }
  if (!refused.empty()) {
    throw FormatError("RTDE setup refused by the controller: " + refused +
                      " (remove unknown variables; IN_USE inputs are owned by another RTDE client or fieldbus)");
  }
  if (recipe.id == 0) {
    throw FormatError("RTDE setup reply: recipe id 0 (the controller rejected the recipe)");
  }
  return recipe;
}

std::vector<std::uint8_t> encodeTextMessage(const TextMessage& m) {
  if (m.message.size() > 255 || m.source.size() > 255) {
    throw InvalidArgumentError("RTDE text message: message and source must each be at most 255 bytes");
  }
  BeWriter w;
  w.u8(static_cast<std::uint8_t>(m.message.size()));
  w.string(m.message);
  w.u8(static_cast<std::uint8_t>(m.source.size()));
  w.string(m.source);
  w.u8(static_cast<std::uint8_t>(m.level));
  return encodePackage(PackageType::TextMessage, w.bytes());
}

TextMessage decodeTextMessage(const Package& package) {
  expectType(package, PackageType::TextMessage);
  BeReader r(package.payload, "RTDE_TEXT_MESSAGE");
  TextMessage m;
  m.message = r.string(r.u8("message_length"), "message");
  m.source = r.string(r.u8("source_length"), "source");
  const auto level = r.u8("warning_level");
  if (level > 3) throw FormatError("RTDE_TEXT_MESSAGE: warning level " + std::to_string(level) + " is not 0..3");
  m.level = static_cast<MessageLevel>(level);
  expectEnd(r, package.type);
  return m;
}

std::vector<std::uint8_t> encodeDataPackage(const Recipe& recipe, std::span<const Value> values) {
  if (values.size() != recipe.fields.size()) {
    throw InvalidArgumentError("RTDE data package: " + std::to_string(values.size()) + " values for a recipe of " +
                               std::to_string(recipe.fields.size()) + " fields");
  }
  BeWriter w;
  w.u8(recipe.id);
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (typeOf(values[i]) != recipe.fields[i].type) {
      throw InvalidArgumentError("RTDE data package: field '" + recipe.fields[i].name + "' is " +
                                 toString(recipe.fields[i].type) + " but the value given is " +
                                 toString(typeOf(values[i])));
    }
    std::visit(
        [&w](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, bool>) {
            w.u8(v ? 1 : 0);
          } else if constexpr (std::is_same_v<T, std::uint8_t>) {
            w.u8(v);
          } else if constexpr (std::is_same_v<T, std::uint32_t>) {
            w.u32(v);
          } else if constexpr (std::is_same_v<T, std::uint64_t>) {
            w.u64(v);
          } else if constexpr (std::is_same_v<T, std::int32_t>) {
            w.i32(v);
          } else if constexpr (std::is_same_v<T, double>) {
            w.f64(v);
          } else if constexpr (std::is_same_v<T, std::array<double, 3>> || std::is_same_v<T, std::array<double, 6>>) {
            for (double d : v) w.f64(d);
          } else if constexpr (std::is_same_v<T, std::array<std::int32_t, 6>>) {
            for (auto d : v) w.i32(d);
          } else {
            for (auto d : v) w.u32(d);
          }
        },
        values[i]);
  }
  return encodePackage(PackageType::DataPackage, w.bytes());
}

std::vector<Value> decodeDataPackage(const Package& package, const Recipe& recipe) {
  expectType(package, PackageType::DataPackage);
  BeReader r(package.payload, "RTDE_DATA_PACKAGE");
  const auto id = r.u8("recipe_id");
  if (id != recipe.id) {
    throw FormatError("RTDE_DATA_PACKAGE: recipe id " + std::to_string(id) + " but the recipe in use has id " +
                      std::to_string(recipe.id));
  }
  if (r.remaining() != recipe.payloadSize()) {
    throw FormatError("RTDE_DATA_PACKAGE: " + std::to_string(r.remaining()) + " payload bytes but recipe " +
                      std::to_string(recipe.id) + " needs " + std::to_string(recipe.payloadSize()));
  }
  std::vector<Value> out;
  out.reserve(recipe.fields.size());
  for (const auto& f : recipe.fields) {
    switch (f.type) {
      case FieldType::Bool: {
        const auto b = r.u8(f.name);
        if (b > 1) throw FormatError("RTDE_DATA_PACKAGE: BOOL field '" + f.name + "' holds " + std::to_string(b));
        out.emplace_back(b == 1);
        break;
      }
      case FieldType::Uint8: out.emplace_back(r.u8(f.name)); break;
      case FieldType::Uint32: out.emplace_back(r.u32(f.name)); break;
      case FieldType::Uint64: out.emplace_back(r.u64(f.name)); break;
      case FieldType::Int32: out.emplace_back(r.i32(f.name)); break;
      case FieldType::Double: out.emplace_back(r.f64(f.name)); break;
      case FieldType::Vector3d: {
        std::array<double, 3> v{};
        for (auto& d : v) d = r.f64(f.name);
        out.emplace_back(v);
        break;
      }
      case FieldType::Vector6d: {
        std::array<double, 6> v{};
        for (auto& d : v) d = r.f64(f.name);
        out.emplace_back(v);
        break;
      }
      case FieldType::Vector6Int32: {
        std::array<std::int32_t, 6> v{};
        for (auto& d : v) d = r.i32(f.name);
        out.emplace_back(v);
        break;
      }
      case FieldType::Vector6Uint32: {
        std::array<std::uint32_t, 6> v{};
        for (auto& d : v) d = r.u32(f.name);
        out.emplace_back(v);
        break;
      }
    }
  }
  return out;
}

}  // namespace mrsns::robot::rtde
