// Tracing output ports to a JSON-lines file: each traced port gets a probe (a circular
// connection the engine adds), drained here on the control thread, off the data path.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "polyport/runtime/engine.hpp"

namespace polyport::daemon {

class Tracer {
 public:
  Tracer() = default;
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;
  ~Tracer();

  Result<void> open(const std::string& file);
  Result<void> add(Engine& engine, const std::string& port_path, std::uint32_t depth);
  // Writes every sample waiting in the probes; returns how many.
  std::size_t drain();
  bool active() const noexcept { return out_ != nullptr; }
  std::uint64_t lost() const;

 private:
  struct Probe {
    std::string path;
    DataInPort* port;
    std::vector<std::byte> buffer;
  };
  std::FILE* out_ = nullptr;
  std::vector<Probe> probes_;
  const Engine* engine_ = nullptr;
};

// `polyportctl trace`: each admin client's trace of a port is a probe of its own, drained on
// the engine's control thread (polyportd's main thread, every 100 ms while one is open) into
// lines of the client's streamed reply; never on the forwarding path. A trace ends when its
// count or duration is reached, or when its client leaves; its probe is then taken off the port.
class TraceStreams {
 public:
  static constexpr std::uint32_t kDepth = 1024;  // samples buffered per trace between drains
  // Lines of a client's streamed reply (AdminServer::send).
  using Send = std::function<void(std::uint64_t client, std::string lines, bool last)>;

  // Opens a trace for `client`; the error reply when the port cannot be traced.
  std::optional<std::string> open(Engine& engine, std::uint64_t client, const nlohmann::json& id,
                                  const std::string& port, std::optional<std::int64_t> count,
                                  std::optional<double> duration_s);
  // Sends what the probes hold, and the final reply of traces that are done.
  void drain(Engine& engine, const Send& send);
  // The client left: its trace ends without a reply.
  void close(Engine& engine, std::uint64_t client);
  bool active() const noexcept { return !streams_.empty(); }

 private:
  struct Stream {
    std::uint64_t client;
    nlohmann::json id;
    std::string port;
    DataInPort* probe;
    std::vector<std::byte> buffer;
    std::optional<std::int64_t> count;
    std::optional<std::chrono::steady_clock::time_point> deadline;
    std::int64_t sent = 0;
  };
  void finish(Engine& engine, Stream& stream, const char* reason, const Send& send);
  std::vector<Stream> streams_;
};

}  // namespace polyport::daemon
