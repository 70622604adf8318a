// Recording the bridged traffic of chosen connections as an LCM event log (LCM's own log API,
// liblcm's lcm_eventlog_*), so lcm-logplayer and lcm-spy replay and inspect it.
//
// Off the forwarding path: each recorded connection's source port gets a tap, a pull-mode
// circular connection of its own (like the tracer's probes) into an input port that takes the
// source's wire format, so the tap copies the source's bytes untouched into preallocated
// slots of the port's max sample size: no decode, no allocation, no lock on the writer's
// thread. When the tap is full the oldest waiting sample is dropped and counted; the
// forwarding path never waits for the recorder. A writer thread of the recorder's own drains
// the taps, encodes where the source's format is the in-process layout, stamps each event
// with the sample's entry time moved onto CLOCK_REALTIME (one offset taken at open) and writes
// it to the log. Taps are made before the engine starts and taken off after it stopped
// (control thread).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "polyport/base/result.hpp"
#include "polyport/codecs/codec.hpp"
#include "polyport/runtime/component.hpp"
#include "polyport/runtime/engine.hpp"

struct _lcm_eventlog_t;

namespace polyport::daemon {

class Recorder {
 public:
  Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;
  ~Recorder();

  // Opens `file` (truncated) and taps the chosen data connections ("Src.port->Dst.port",
  // spaces ignored); none chosen: every data connection of the application. `depth`: samples
  // each tap holds between the writer's turns. Control thread, before engine.start().
  Result<void> open(Engine& engine, const std::string& file, const std::vector<std::string>& connections,
                    std::uint32_t depth);
  void start();
  // Writes what the taps still hold, closes the log and takes the taps off their ports.
  // Control thread, after engine.stop().
  void stop();
  bool active() const noexcept { return log_ != nullptr; }

  // {"file", "events", "record_dropped", "connections": [{connection, channel, encoding,
  // recorded, dropped}]}; also adds "recorded" and "record_dropped" to the stats' entries of
  // the recorded connections.
  void stats(nlohmann::json& out) const;

  // The channel an LCM source publishes on, or the connection's name ("Src.port->Dst.port").
  static std::string channel_name(const Engine& engine, const Connection& connection);

 private:
  struct Tap {
    std::string channel;
    std::string encoding;               // lcm, xcdr1, xcdr2, dbc, flat (docs/CONTROL.md)
    DataOutPort* source = nullptr;
    DataInPort* port = nullptr;         // owned by component_: the tap's reading end
    std::unique_ptr<Connection> link;   // source -> port, circular
    std::unique_ptr<Codec> lcm;         // flat sources of a type LCM can carry: encoded here
    std::vector<std::byte> sample;      // writer thread's scratch
    std::vector<std::byte> encoded;
    std::atomic<std::uint64_t> recorded{0};
    std::atomic<std::uint64_t> failed{0};  // could not be encoded or written
    std::uint64_t dropped() const noexcept;
  };
  struct Recorded {
    std::string connection;  // Connection::name()
    Tap* tap;
  };

  void run() noexcept;
  std::size_t drain_once() noexcept;
  void write(Tap& tap, const SampleMeta& meta) noexcept;

  std::string file_;
  _lcm_eventlog_t* log_ = nullptr;
  std::unique_ptr<Component> component_;
  std::vector<std::unique_ptr<Tap>> taps_;
  std::vector<Recorded> recorded_;
  std::int64_t wall_offset_ns_ = 0;  // CLOCK_REALTIME - CLOCK_MONOTONIC, taken at open
  std::atomic<bool> running_{false};
  std::thread writer_;
  std::atomic<std::uint64_t> events_{0};
};

}  // namespace polyport::daemon
