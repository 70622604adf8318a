#include "tracer.hpp"

#include <cerrno>
#include <cstring>

#include <spdlog/spdlog.h>

#include "admin_protocol.hpp"
#include "polyport/types/types.hpp"

namespace polyport::daemon {

Tracer::~Tracer() {
  if (out_) std::fclose(out_);
}

Result<void> Tracer::open(const std::string& file) {
  out_ = std::fopen(file.c_str(), "w");
  if (!out_) return make_error("cannot write trace file '" + file + "': " + std::strerror(errno));
  return {};
}

Result<void> Tracer::add(Engine& engine, const std::string& port_path, std::uint32_t depth) {
  Result<DataInPort*> probe = engine.add_probe(port_path, depth);
  if (!probe) return probe.error();
  engine_ = &engine;
  probes_.push_back(Probe{port_path, probe.value(), std::vector<std::byte>(probe.value()->max_sample_bytes() + 1)});
  return {};
}

std::size_t Tracer::drain() {
  std::size_t written = 0;
  for (Probe& probe : probes_) {
    SampleMeta meta{};
    // At most one probe's depth per call, so a writer faster than the formatting here cannot
    // keep the control thread from its signals; the circular probe drops the oldest instead.
    for (std::uint32_t n = 0; n < probe.port->depth() &&
                              probe.port->read(probe.buffer.data(), static_cast<std::uint32_t>(probe.buffer.size()), &meta) == Status::ok;
         ++n) {
      const std::string value = probe.port->type() ? sample_to_json(*probe.port->type(), probe.buffer.data(), meta.size)
                                                   : std::string("null");
      std::fprintf(out_, "{\"t_ns\":%lld,\"port\":\"%s\",\"value\":%s}\n", static_cast<long long>(meta.t_in.ns),
                   probe.path.c_str(), value.c_str());
      ++written;
    }
  }
  if (written) std::fflush(out_);
  return written;
}

std::uint64_t Tracer::lost() const {
  std::uint64_t lost = 0;
  for (const Probe& probe : probes_) {
    for (Connection* c : probe.port->connections().current()) lost += c->counters().dropped();
  }
  return lost;
}

std::optional<std::string> TraceStreams::open(Engine& engine, std::uint64_t client, const nlohmann::json& id,
                                              const std::string& port, std::optional<std::int64_t> count,
                                              std::optional<double> duration_s) {
  // A port that is not an output data port: the error names what the application has.
  Result<DataInPort*> probe = engine.add_probe(port, kDepth);
  if (!probe) {
    std::string outputs;
    nlohmann::json graph;
    engine.describe(graph);
    for (const auto& component : graph["components"]) {
      for (const auto& p : component.value("ports", nlohmann::json::array())) {
        if (p.value("kind", "") == "data" && p.value("direction", "") == "output") {
          outputs += (outputs.empty() ? "" : ", ") + component.value("name", "") + "." + p.value("name", "");
        }
      }
    }
    return admin::error_reply(id, admin::kUnknownPort,
                              "no output data port '" + port + "' (output data ports: " + outputs + ")");
  }
  Stream stream{client, id, port, probe.value(), std::vector<std::byte>(probe.value()->max_sample_bytes() + 1), count,
                std::nullopt};
  if (duration_s) {
    stream.deadline = std::chrono::steady_clock::now() +
                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(*duration_s));
  }
  streams_.push_back(std::move(stream));
  spdlog::info("admin: tracing {} for a client", port);
  return std::nullopt;
}

void TraceStreams::drain(Engine& engine, const Send& send) {
  const auto now = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < streams_.size();) {
    Stream& s = streams_[i];
    std::string lines;
    SampleMeta meta{};
    // At most one probe's depth per call, as Tracer::drain: the circular probe drops the
    // oldest when the writer is faster than this.
    for (std::uint32_t n = 0; n < kDepth && (!s.count || s.sent < *s.count) &&
                              s.probe->read(s.buffer.data(), static_cast<std::uint32_t>(s.buffer.size()), &meta) == Status::ok;
         ++n) {
      const std::string value = s.probe->type() ? sample_to_json(*s.probe->type(), s.buffer.data(), meta.size)
                                                : std::string("null");
      lines += admin::sample_line(s.id, meta.t_in.ns, s.port, value);
      ++s.sent;
    }
    if (!lines.empty()) send(s.client, std::move(lines), false);
    const char* reason = nullptr;
    if (s.count && s.sent >= *s.count) reason = "count";
    else if (s.deadline && now >= *s.deadline) reason = "duration";
    if (reason == nullptr) {
      ++i;
      continue;
    }
    finish(engine, s, reason, send);
    streams_.erase(streams_.begin() + static_cast<std::ptrdiff_t>(i));
  }
}

void TraceStreams::finish(Engine& engine, Stream& s, const char* reason, const Send& send) {
  std::uint64_t lost = 0;
  for (Connection* c : s.probe->connections().current()) lost += c->counters().dropped();
  (void)engine.remove_probe(s.probe);
  send(s.client,
       admin::ok_reply(s.id, {{"port", s.port}, {"samples", s.sent}, {"lost", lost}, {"end", reason}}), true);
}

void TraceStreams::close(Engine& engine, std::uint64_t client) {
  for (auto it = streams_.begin(); it != streams_.end(); ++it) {
    if (it->client != client) continue;
    (void)engine.remove_probe(it->probe);
    spdlog::info("admin: trace of {} ended: its client left after {} sample(s)", it->port, it->sent);
    streams_.erase(it);
    return;
  }
}

}  // namespace polyport::daemon
