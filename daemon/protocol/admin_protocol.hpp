// The admin socket's protocol (docs/CONTROL.md): one JSON object per line, at most
// kMaxRequestLine bytes, `{"v":1,"id":...,"cmd":"...",...fields of the command}` in,
// `{"v":1,"id":...,"ok":true,"result":...}` or `{"v":1,"id":...,"ok":false,"code":"...",
// "error":"..."}` out. Pure functions and a line buffer, no I/O: the control thread of
// polyportd and polyportctl both use them, and tests/fuzz/fuzz_admin_request.cpp fuzzes them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

namespace polyport::admin {

inline constexpr int kProtocolVersion = 1;
// A request line longer than this (newline excluded) gets an error reply and the client is
// cut off.
inline constexpr std::size_t kMaxRequestLine = 64 * 1024;

// The commands of protocol version 1.
enum class Command { hello, list, stats, activate, deactivate, reset, get, set, connect, disconnect, reload, trace, condition };
std::string_view to_string(Command command) noexcept;
// Lifecycle commands, get and set name a component.
bool needs_component(Command command) noexcept;

struct Request {
  nlohmann::json id;      // echoed in the reply (null when the request had none)
  Command command = Command::hello;
  std::string component;  // activate, deactivate, reset, get, set
  std::string property;   // get (empty: every property), set
  std::string value;      // set: the new value as text (a JSON number or boolean, written out)
  std::string source;     // connect, disconnect: "Component.port"
  std::string target;     // connect, disconnect: "Component.port"
  std::string policy;     // connect (empty: the input port's)
  std::optional<std::int64_t> depth;  // connect
  std::string port;                   // trace: "Component.port", an output data port
  std::optional<std::int64_t> count;  // trace: stop after this many samples (at least 1)
  std::optional<double> duration_s;   // trace: stop after this many seconds (more than 0)
  // condition (`port`: the client's event input): on or off; when on, "single" or
  // "continuous" (empty: continuous) and parameters by name, each overriding the threshold
  // of the fields whose `param` it names.
  bool active = false;
  std::string mode;
  std::vector<std::pair<std::string, double>> parameters;
};

// Error codes of a refused request (the reply's "code"); polyportctl maps access_denied to
// its exit code 3 and every other to 1.
inline constexpr const char* kBadRequest = "bad_request";
inline constexpr const char* kTooLong = "too_long";
inline constexpr const char* kUnknownCommand = "unknown_command";
inline constexpr const char* kUnknownComponent = "unknown_component";
inline constexpr const char* kUnknownProperty = "unknown_property";
inline constexpr const char* kBadValue = "bad_value";
inline constexpr const char* kUnsupported = "unsupported";
inline constexpr const char* kInvalidConnection = "invalid_connection";
inline constexpr const char* kUnknownConnection = "unknown_connection";
inline constexpr const char* kUnknownPort = "unknown_port";
inline constexpr const char* kRefused = "refused";
inline constexpr const char* kAccessDenied = "access_denied";

struct ParseError {
  nlohmann::json id;  // the request's id when it could be read, else null
  std::string code;
  std::string message;
};

// Parses one request line (without its newline). Never throws.
std::optional<Request> parse_request(std::string_view line, ParseError& error);

// Reply lines, newline included. Never throw (strings that are not UTF-8 are replaced).
std::string ok_reply(const nlohmann::json& id, const nlohmann::json& result);
std::string error_reply(const nlohmann::json& id, std::string_view code, std::string_view message);
// One line of a streamed reply (trace): `{"v":1,"id":...,"ok":true,"sample":{"t_ns":...,
// "port":"...","value":...}}`; `value_json` is written as it is (JSON text). The stream ends
// with an ok_reply or an error_reply.
std::string sample_line(const nlohmann::json& id, std::int64_t t_ns, std::string_view port, std::string_view value_json);
// A request line, newline included (polyportctl): the fields `request.command` takes.
std::string request_line(const Request& request);
std::string request_line(const nlohmann::json& id, Command command, std::string_view component = {});

// Where daemons put their sockets by default: $XDG_RUNTIME_DIR/polyport when XDG_RUNTIME_DIR
// is set, else /run/polyport (polyportd-<pid>.sock in it).
std::string default_socket_dir();

// Splits a byte stream into lines of at most `max` bytes.
class LineBuffer {
 public:
  explicit LineBuffer(std::size_t max = kMaxRequestLine) : max_(max) {}
  enum class Next { line, need_more, too_long };
  void append(const char* data, std::size_t size) { pending_.append(data, size); }
  // The next complete line (newline removed, a trailing '\r' too) into `line`; too_long once
  // a line (complete or not) is longer than `max`: the stream is then unusable.
  Next next(std::string& line);
  std::size_t buffered() const noexcept { return pending_.size() - start_; }

 private:
  std::size_t max_;
  std::string pending_;
  std::size_t start_ = 0;  // first byte not yet returned
  std::size_t scanned_ = 0;  // bytes after start_ known to hold no newline
};

}  // namespace polyport::admin
