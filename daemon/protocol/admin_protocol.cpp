#include "admin_protocol.hpp"

#include <array>
#include <cstdlib>
#include <utility>

namespace polyport::admin {
namespace {

constexpr std::array<std::pair<std::string_view, Command>, 6> kCommands{{
    {"hello", Command::hello},
    {"list", Command::list},
    {"stats", Command::stats},
    {"activate", Command::activate},
    {"deactivate", Command::deactivate},
    {"reset", Command::reset},
}};

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

bool needs_component(Command command) noexcept {
  return command == Command::activate || command == Command::deactivate || command == Command::reset;
}

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
    error.message = "unknown command '" + name + "' (known: hello, list, stats, activate, deactivate, reset)";
    return std::nullopt;
  }
  auto component = j.find("component");
  if (needs_component(request.command)) {
    if (component == j.end() || !component->is_string() || component->get_ref<const std::string&>().empty()) {
      error.code = kBadRequest;
      error.message = "'" + name + "' needs \"component\": the name of a component";
      return std::nullopt;
    }
    request.component = component->get<std::string>();
  } else if (component != j.end()) {
    error.code = kBadRequest;
    error.message = "'" + name + "' takes no \"component\"";
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

std::string request_line(const nlohmann::json& id, Command command, std::string_view component) {
  nlohmann::json j{{"v", kProtocolVersion}, {"id", id}, {"cmd", to_string(command)}};
  if (needs_component(command)) j["component"] = component;
  return dump(j);
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
