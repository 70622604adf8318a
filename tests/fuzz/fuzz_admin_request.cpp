// The admin socket's request path as the daemon's control thread runs it: bytes from a
// client, split into lines by LineBuffer (in chunks, as recv delivers them), each line
// parsed, an error reply built for a refused one (its id echoed), request_line round-tripped
// for an accepted one (every command: hello ... reset, get / set of properties, connect /
// disconnect with policy and depth, trace of a port with count and duration, condition with
// active, mode and parameters) and a
// streamed sample line for an accepted trace.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "admin_protocol.hpp"

namespace {

// Whether every parameter name is UTF-8 (and so comes back as it was).
bool utf8_names(const std::vector<std::pair<std::string, double>>& parameters) {
  try {
    for (const auto& parameter : parameters) (void)nlohmann::json(parameter.first).dump();
  } catch (const nlohmann::json::exception&) {
    return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace polyport::admin;
  if (size == 0) return 0;
  // The first byte picks the chunk size, so the framing is fuzzed across boundaries.
  const std::size_t chunk = 1 + data[0] % 64;
  LineBuffer in(4096);  // a small bound, so the too_long path is reached
  std::string line;
  for (std::size_t at = 1; at < size; at += chunk) {
    const std::size_t n = std::min(chunk, size - at);
    in.append(reinterpret_cast<const char*>(data + at), n);
    for (;;) {
      const LineBuffer::Next next = in.next(line);
      if (next == LineBuffer::Next::need_more) break;
      if (next == LineBuffer::Next::too_long) return 0;  // the daemon cuts the client off
      if (line.size() > 4096) std::abort();
      ParseError error;
      const auto request = parse_request(line, error);
      if (!request) {
        if (error.code.empty() || error.message.empty()) std::abort();
        const std::string reply = error_reply(error.id, error.code, error.message);
        if (reply.empty() || reply.back() != '\n') std::abort();
        continue;
      }
      const std::string again = request_line(*request);
      ParseError error2;
      const auto back = parse_request(std::string_view(again).substr(0, again.size() - 1), error2);
      // A name that is not UTF-8 is replaced on the way out; everything else survives the
      // round trip: the command, a connection's depth, a condition's switch, mode and
      // parameters (finite numbers: JSON has no infinity), and which fields are there.
      if (!back || back->command != request->command || back->depth != request->depth ||
          back->count != request->count || back->duration_s != request->duration_s ||
          back->active != request->active || back->mode != request->mode ||
          (back->parameters != request->parameters && utf8_names(request->parameters))) {
        std::abort();
      }
      if (back->component.empty() != request->component.empty() || back->property.empty() != request->property.empty() ||
          back->source.empty() != request->source.empty() || back->target.empty() != request->target.empty() ||
          back->policy.empty() != request->policy.empty() || back->port.empty() != request->port.empty()) {
        std::abort();
      }
      if (ok_reply(request->id, nullptr).back() != '\n') std::abort();
      if (request->command == Command::trace) {
        const std::string sample = sample_line(request->id, 1, request->port, "{}");
        if (sample.back() != '\n' || sample.find('\n') != sample.size() - 1) std::abort();
      }
    }
  }
  return 0;
}
