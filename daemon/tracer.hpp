// Tracing output ports to a JSON-lines file: each traced port gets a probe (a circular
// connection the engine adds), drained here on the control thread, off the data path.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

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

}  // namespace polyport::daemon
