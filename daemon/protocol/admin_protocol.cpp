#include "admin_protocol.hpp"

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <utility>

namespace polyport::admin {
namespace {

constexpr std::array<std::pair<std::string_view, Command>, 13> kCommands{{
    {"hello", Command::hello},
    {"list", Command::list},
    {"stats", Command::stats},
    {"activate", Command::activate},
    {"deactivate", Command::deactivate},
    {"reset", Command::reset},
    {"get", Command::get},
    {"set", Command::set},
    {"connect", Command::connect},
    {"disconnect", Command::disconnect},
    {"reload", Command::reload},
    {"trace", Command::trace},
    {"condition", Command::condition},
}};

// The fields a request may carry besides v, id and cmd.
enum Field : unsigned {
  kComponent = 1u << 0,
  kProperty = 1u << 1,
  kValue = 1u << 2,
  kSource = 1u << 3,
  kTarget = 1u << 4,
  kPolicy = 1u << 5,
  kDepth = 1u << 6,
  kPort = 1u << 7,
  kCount = 1u << 8,
  kDuration = 1u << 9,
  kActive = 1u << 10,
  kMode = 1u << 11,
  kParameters = 1u << 12,
};
constexpr std::array<std::pair<const char*, Field>, 13> kFields{{
    {"component", kComponent},
    {"property", kProperty},
    {"value", kValue},
    {"source", kSource},
    {"target", kTarget},
    {"policy", kPolicy},
    {"depth", kDepth},
    {"port", kPort},
    {"count", kCount},
    {"duration", kDuration},
    {"active", kActive},
    {"mode", kMode},
    {"parameters", kParameters},
}};

struct Shape {
  unsigned required;
  unsigned optional;
};

Shape shape_of(Command command) noexcept {
  switch (command) {
    case Command::hello:
    case Command::list:
    case Command::stats:
    case Command::reload:
      return {0, 0};
    case Command::activate:
    case Command::deactivate:
    case Command::reset:
      return {kComponent, 0};
    case Command::get:
      return {kComponent, kProperty};
    case Command::set:
      return {kComponent | kProperty | kValue, 0};
    case Command::connect:
      return {kSource | kTarget, kPolicy | kDepth};
    case Command::disconnect:
      return {kSource | kTarget, 0};
    case Command::trace:
      return {kPort, kCount | kDuration};
    case Command::condition:
      return {kPort | kActive, kMode | kParameters};
  }
  return {0, 0};
}

std::string known_commands() {
  std::string out;
  for (const auto& [name, value] : kCommands) out += (out.empty() ? "" : ", ") + std::string(name);
  return out;
}

// A field's value into `request`; the reason in `message` when it is not acceptable.
bool read_field(Field field, const nlohmann::json& v, Request& request, std::string& message) {
  auto text = [&](std::string& out, const char* what) {
    if (!v.is_string() || v.get_ref<const std::string&>().empty()) {
      message = std::string("\"") + what + "\" must be a non-empty string";
      return false;
    }
    out = v.get<std::string>();
    return true;
  };
  auto port = [&](std::string& out, const char* what) {
    if (!text(out, what)) return false;
    const auto dot = out.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == out.size()) {
      message = std::string("\"") + what + "\" must name a port as COMPONENT.PORT, not '" + out + "'";
      return false;
    }
    return true;
  };
  switch (field) {
    case kComponent: return text(request.component, "component");
    case kProperty: return text(request.property, "property");
    case kPolicy: return text(request.policy, "policy");
    case kSource: return port(request.source, "source");
    case kTarget: return port(request.target, "target");
    case kPort: return port(request.port, "port");
    case kCount:
      if (v.is_number_unsigned() && v.get<std::uint64_t>() >= 1 && v.get<std::uint64_t>() <= static_cast<std::uint64_t>(INT64_MAX)) {
        request.count = static_cast<std::int64_t>(v.get<std::uint64_t>());
        return true;
      }
      if (v.is_number_integer() && !v.is_number_unsigned() && v.get<std::int64_t>() >= 1) {
        request.count = v.get<std::int64_t>();
        return true;
      }
      message = "\"count\" must be an integer of at least 1";
      return false;
    case kDuration:
      // Up to about 31 years: a bound that keeps the deadline arithmetic in range.
      if (v.is_number() && v.get<double>() > 0 && v.get<double>() <= 1e9) {
        request.duration_s = v.get<double>();
        return true;
      }
      message = "\"duration\" must be a number of seconds, more than 0 (at most 1e9)";
      return false;
    case kValue:
      if (v.is_string()) request.value = v.get<std::string>();
      else if (v.is_boolean() || v.is_number()) request.value = v.dump();
      else {
        message = "\"value\" must be a string, a number or a boolean";
        return false;
      }
      return true;
    case kActive:
      if (!v.is_boolean()) {
        message = "\"active\" must be true or false";
        return false;
      }
      request.active = v.get<bool>();
      return true;
    case kMode:
      if (!v.is_string() || (v.get_ref<const std::string&>() != "single" && v.get_ref<const std::string&>() != "continuous")) {
        message = "\"mode\" must be \"single\" or \"continuous\"";
        return false;
      }
      request.mode = v.get<std::string>();
      return true;
    case kParameters:
      if (!v.is_object()) {
        message = "\"parameters\" must be an object of finite numbers by parameter name";
        return false;
      }
      for (const auto& [name, value] : v.items()) {
        // JSON has no infinity (and the parser refuses 1e400): checked all the same, since a
        // threshold of infinity could not be shown back.
        if (name.empty() || !value.is_number() || !std::isfinite(value.get<double>())) {
          message = "\"parameters\" must be an object of finite numbers by parameter name ('" + name + "' is not)";
          return false;
        }
        request.parameters.emplace_back(name, value.get<double>());
      }
      return true;
    case kDepth:
      if (v.is_number_integer() && !v.is_number_unsigned()) {
        request.depth = v.get<std::int64_t>();
        return true;
      }
      if (v.is_number_unsigned() && v.get<std::uint64_t>() <= static_cast<std::uint64_t>(INT64_MAX)) {
        request.depth = static_cast<std::int64_t>(v.get<std::uint64_t>());
        return true;
      }
      message = "\"depth\" must be an integer";
      return false;
  }
  return false;
}

std::string dump(const nlohmann::json& j) {
  // Replaces bytes that are not UTF-8 instead of throwing.
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace

std::string_view to_string(Command command) noexcept {
  for (const auto& [name, value] : kCommands) {
    if (value == command) return name;
  }
  return "?";
}

bool needs_component(Command command) noexcept { return (shape_of(command).required & kComponent) != 0; }

std::optional<Request> parse_request(std::string_view line, ParseError& error) {
  error = ParseError{};
  if (line.size() > kMaxRequestLine) {
    error.code = kTooLong;
    error.message = "request longer than " + std::to_string(kMaxRequestLine) + " bytes";
    return std::nullopt;
  }
  // nlohmann's parser keeps its own stack, so deep nesting within the bound is no danger.
  nlohmann::json j = nlohmann::json::parse(line.begin(), line.end(), nullptr, false);
  if (j.is_discarded()) {
    error.code = kBadRequest;
    error.message = "not JSON: each request is one JSON object on one line";
    return std::nullopt;
  }
  if (!j.is_object()) {
    error.code = kBadRequest;
    error.message = "a request is a JSON object";
    return std::nullopt;
  }
  Request request;
  if (auto it = j.find("id"); it != j.end()) {
    if (!it->is_number_integer() && !it->is_number_unsigned() && !it->is_string() && !it->is_null()) {
      error.code = kBadRequest;
      error.message = "\"id\" must be an integer or a string";
      return std::nullopt;
    }
    request.id = *it;
    error.id = *it;
  }
  auto v = j.find("v");
  if (v == j.end() || !(v->is_number_integer() || v->is_number_unsigned())) {
    error.code = kBadRequest;
    error.message = "\"v\" (the protocol version, 1) is missing or not an integer";
    return std::nullopt;
  }
  if (v->get<std::int64_t>() != kProtocolVersion) {
    error.code = kBadRequest;
    error.message = "protocol version " + v->dump() + " is not supported (this daemon speaks version " +
                    std::to_string(kProtocolVersion) + ")";
    return std::nullopt;
  }
  auto cmd = j.find("cmd");
  if (cmd == j.end() || !cmd->is_string()) {
    error.code = kBadRequest;
    error.message = "\"cmd\" is missing or not a string";
    return std::nullopt;
  }
  const std::string& name = cmd->get_ref<const std::string&>();
  bool known = false;
  for (const auto& [text, value] : kCommands) {
    if (text == name) {
      request.command = value;
      known = true;
    }
  }
  if (!known) {
    error.code = kUnknownCommand;
    error.message = "unknown command '" + name + "' (known: " + known_commands() + ")";
    return std::nullopt;
  }
  const Shape shape = shape_of(request.command);
  for (const auto& [field_name, field] : kFields) {
    auto it = j.find(field_name);
    if (it == j.end()) {
      if ((shape.required & field) == 0) continue;
      error.code = kBadRequest;
      error.message = "'" + name + "' needs \"" + field_name + "\"";
      if (field == kComponent) error.message += ": the name of a component";
      if (field == kSource || field == kTarget) error.message += ": a port as COMPONENT.PORT";
      return std::nullopt;
    }
    if (((shape.required | shape.optional) & field) == 0) {
      error.code = kBadRequest;
      error.message = "'" + name + "' takes no \"" + field_name + "\"";
      return std::nullopt;
    }
    if (!read_field(field, *it, request, error.message)) {
      error.code = kBadRequest;
      error.message = "'" + name + "': " + error.message;
      return std::nullopt;
    }
  }
  if (request.command == Command::condition && !request.active &&
      (j.contains("mode") || j.contains("parameters"))) {
    error.code = kBadRequest;
    error.message = "'condition' takes \"mode\" and \"parameters\" only with \"active\": true";
    return std::nullopt;
  }
  return request;
}

std::string ok_reply(const nlohmann::json& id, const nlohmann::json& result) {
  return dump({{"v", kProtocolVersion}, {"id", id}, {"ok", true}, {"result", result}});
}

std::string error_reply(const nlohmann::json& id, std::string_view code, std::string_view message) {
  return dump({{"v", kProtocolVersion}, {"id", id}, {"ok", false}, {"code", code}, {"error", message}});
}

std::string sample_line(const nlohmann::json& id, std::int64_t t_ns, std::string_view port, std::string_view value_json) {
  std::string line = "{\"v\":" + std::to_string(kProtocolVersion) + ",\"id\":";
  line += id.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  line += ",\"ok\":true,\"sample\":{\"t_ns\":" + std::to_string(t_ns) + ",\"port\":";
  line += nlohmann::json(std::string(port)).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  line += ",\"value\":";
  line += value_json.empty() ? std::string_view("null") : value_json;
  line += "}}\n";
  return line;
}

std::string request_line(const Request& request) {
  nlohmann::json j{{"v", kProtocolVersion}, {"id", request.id}, {"cmd", to_string(request.command)}};
  const Shape shape = shape_of(request.command);
  const unsigned fields = shape.required | shape.optional;
  if (fields & kComponent) j["component"] = request.component;
  if ((fields & kProperty) && ((shape.required & kProperty) || !request.property.empty())) {
    j["property"] = request.property;
  }
  if (fields & kValue) j["value"] = request.value;
  if (fields & kSource) j["source"] = request.source;
  if (fields & kTarget) j["target"] = request.target;
  if ((fields & kPolicy) && !request.policy.empty()) j["policy"] = request.policy;
  if ((fields & kDepth) && request.depth) j["depth"] = *request.depth;
  if (fields & kPort) j["port"] = request.port;
  if ((fields & kCount) && request.count) j["count"] = *request.count;
  if ((fields & kDuration) && request.duration_s) j["duration"] = *request.duration_s;
  if (fields & kActive) j["active"] = request.active;
  if ((fields & kMode) && !request.mode.empty()) j["mode"] = request.mode;
  if ((fields & kParameters) && !request.parameters.empty()) {
    nlohmann::json parameters = nlohmann::json::object();
    for (const auto& [name, value] : request.parameters) parameters[name] = value;
    j["parameters"] = std::move(parameters);
  }
  return dump(j);
}

std::string request_line(const nlohmann::json& id, Command command, std::string_view component) {
  Request request;
  request.id = id;
  request.command = command;
  request.component = component;
  return request_line(request);
}

std::string default_socket_dir() {
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  if (runtime != nullptr && runtime[0] != '\0') return std::string(runtime) + "/polyport";
  return "/run/polyport";
}

LineBuffer::Next LineBuffer::next(std::string& line) {
  const std::size_t from = start_ + scanned_;
  const std::size_t newline = pending_.find('\n', from);
  if (newline == std::string::npos) {
    scanned_ = pending_.size() - start_;
    if (scanned_ > max_) return Next::too_long;
    // Keeps the buffer from creeping: drop what was returned once it is most of it.
    if (start_ > 0 && start_ >= pending_.size() / 2) {
      pending_.erase(0, start_);
      start_ = 0;
    }
    return Next::need_more;
  }
  std::size_t length = newline - start_;
  if (length > max_) return Next::too_long;
  if (length > 0 && pending_[newline - 1] == '\r') --length;
  line.assign(pending_, start_, length);
  start_ = newline + 1;
  scanned_ = 0;
  if (start_ == pending_.size()) {
    pending_.clear();
    start_ = 0;
  }
  return Next::line;
}

}  // namespace polyport::admin
