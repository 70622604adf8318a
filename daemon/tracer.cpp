#include "tracer.hpp"

#include <cerrno>
#include <cstring>

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

}  // namespace polyport::daemon
