#include "recorder.hpp"

#include <lcm/eventlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "polyport/runtime/connection.hpp"
#include "polyport/runtime/model.hpp"

namespace polyport::daemon {
namespace {

std::string without_spaces(std::string text) {
  text.erase(std::remove(text.begin(), text.end(), ' '), text.end());
  return text;
}

// A connection of the application graph (not a tracer's probe) carrying data.
bool recordable(const Engine& engine, const Connection& c) {
  return c.source().kind() == PortKind::data && engine.find_component(c.target().owner().name()) == &c.target().owner() &&
         engine.find_component(c.source().owner().name()) == &c.source().owner();
}

// The samples each writer pass takes from one tap at most, so one busy tap cannot starve the
// others of the writer's time.
constexpr std::uint32_t kBatch = 256;

}  // namespace

std::uint64_t Recorder::Tap::dropped() const noexcept {
  return link->counters().dropped() + failed.load(std::memory_order_relaxed);
}

Recorder::Recorder() = default;

Recorder::~Recorder() { stop(); }

std::string Recorder::channel_name(const Engine& engine, const Connection& connection) {
  const DataOutPort& source = connection.source();
  if (source.wire_format() == WireFormat::lcm) {
    // The LCM model tells its channels in its description (lcm_interceptor.cpp).
    if (const Interceptor* interceptor = engine.find_interceptor(source.owner().name())) {
      nlohmann::json description;
      interceptor->describe(description);
      if (description.contains("lcm")) {
        for (const auto& channel : description["lcm"]["channels"]) {
          if (channel.value("port", "") == source.name()) return channel.value("channel", "");
        }
      }
    }
  }
  return without_spaces(connection.name());
}

Result<void> Recorder::open(Engine& engine, const std::string& file, const std::vector<std::string>& connections,
                            std::uint32_t depth) {
  if (depth == 0) return make_error("--record-depth must be at least 1");
  std::vector<Connection*> chosen;
  if (connections.empty()) {
    for (const auto& c : engine.connections()) {
      if (recordable(engine, *c)) chosen.push_back(c.get());
    }
  } else {
    for (const std::string& wanted : connections) {
      Connection* found = nullptr;
      std::string names;
      for (const auto& c : engine.connections()) {
        if (!recordable(engine, *c)) continue;
        const std::string name = without_spaces(c->name());
        if (name == without_spaces(wanted)) found = c.get();
        names += (names.empty() ? "" : ", ") + name;
      }
      if (found == nullptr) {
        return make_error("--record-connection '" + wanted + "': no data connection of that name (connections: " +
                          names + ")");
      }
      if (std::find(chosen.begin(), chosen.end(), found) == chosen.end()) chosen.push_back(found);
    }
  }

  component_ = std::make_unique<Component>("record", "inproc");
  for (Connection* c : chosen) {
    DataOutPort& source = c->source();
    const std::string channel = channel_name(engine, *c);
    // Connections fanning out of one source share its samples: one tap per source and channel.
    Tap* tap = nullptr;
    for (const auto& t : taps_) {
      if (t->source == &source && t->channel == channel) tap = t.get();
    }
    if (tap == nullptr) {
      auto made = std::make_unique<Tap>();
      made->channel = channel;
      made->source = &source;
      made->encoding = std::string(to_string(source.wire_format()));
      made->port = &component_->add_port<DataInPort>(source.full_name(), PortKind::data, source.type(),
                                                     source.max_sample_bytes(), QueuePolicy::circular, depth);
      // The tap takes the source's format, so its connection copies the bytes untouched.
      made->port->set_wire_format(source.wire_format(), source.codec());
      made->sample.resize(source.max_sample_bytes());
      if (source.wire_format() == WireFormat::flat && source.type() != nullptr) {
        // An in-process sample of a type LCM can carry is recorded LCM-encoded, so LCM tools
        // decode it; any other type stays in its flat layout.
        if (Result<std::unique_ptr<Codec>> codec = make_lcm_codec(*source.type()); codec) {
          made->lcm = std::move(codec.value());
          made->encoded.resize(made->lcm->max_wire_size(source.max_sample_bytes()));
          made->encoding = "lcm";
        }
      }
      made->link = std::make_unique<Connection>(source, *made->port, QueuePolicy::circular, depth);
      tap = made.get();
      taps_.push_back(std::move(made));
    }
    recorded_.push_back(Recorded{c->name(), tap});
  }

  log_ = lcm_eventlog_create(file.c_str(), "w");
  if (log_ == nullptr) {
    taps_.clear();
    recorded_.clear();
    return make_error("cannot write the recording '" + file + "': " + std::strerror(errno));
  }
  file_ = file;
  // Wired last: nothing is tapped unless the log is open.
  for (const auto& tap : taps_) {
    tap->port->connections().add(*tap->link);
    tap->source->connections().add(*tap->link);
  }
  return {};
}

void Recorder::start() {
  if (log_ == nullptr || running_.load()) return;
  const std::int64_t mono = mono_now().ns;
  wall_offset_ns_ = wall_now().ns - mono;
  running_.store(true, std::memory_order_release);
  writer_ = std::thread([this] { run(); });
}

void Recorder::run() noexcept {
  pthread_setname_np(pthread_self(), "pp-record");
  while (running_.load(std::memory_order_acquire)) {
    // The taps have no wake-up of their own (the forwarding path only copies into them): a
    // short sleep when there was nothing, at once again when there was.
    if (drain_once() == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

std::size_t Recorder::drain_once() noexcept {
  std::size_t taken = 0;
  for (const auto& tap : taps_) {
    SampleMeta meta{};
    for (std::uint32_t n = 0; n < kBatch; ++n) {
      if (tap->port->read(tap->sample.data(), static_cast<std::uint32_t>(tap->sample.size()), &meta) != Status::ok) break;
      write(*tap, meta);
      ++taken;
    }
  }
  return taken;
}

void Recorder::write(Tap& tap, const SampleMeta& meta) noexcept {
  const std::byte* data = tap.sample.data();
  std::uint32_t size = meta.size;
  if (tap.lcm) {
    const CodecResult encoded = tap.lcm->encode(data, meta.size, tap.encoded.data(),
                                                static_cast<std::uint32_t>(tap.encoded.size()));
    if (!encoded.ok()) {
      tap.failed.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    data = tap.encoded.data();
    size = encoded.size;
  }
  lcm_eventlog_event_t event{};
  event.timestamp = (meta.t_in.ns + wall_offset_ns_) / 1000;  // microseconds since the epoch
  event.channellen = static_cast<std::int32_t>(tap.channel.size());
  event.datalen = static_cast<std::int32_t>(size);
  event.channel = tap.channel.data();
  event.data = const_cast<std::byte*>(data);
  if (lcm_eventlog_write_event(log_, &event) != 0) {
    tap.failed.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  tap.recorded.fetch_add(1, std::memory_order_relaxed);
  events_.fetch_add(1, std::memory_order_relaxed);
}

void Recorder::stop() {
  if (log_ == nullptr) return;
  if (running_.exchange(false)) writer_.join();
  // The engine has stopped: what the taps hold is the end of the recording.
  while (drain_once() > 0) {
  }
  lcm_eventlog_destroy(log_);
  log_ = nullptr;
  for (const auto& tap : taps_) {
    tap->source->connections().remove(*tap->link);
    tap->port->connections().remove(*tap->link);
  }
}

void Recorder::stats(nlohmann::json& out) const {
  if (taps_.empty() && file_.empty()) return;
  nlohmann::json list = nlohmann::json::array();
  std::uint64_t dropped = 0;
  for (const auto& tap : taps_) dropped += tap->dropped();
  for (const Recorded& r : recorded_) {
    const std::uint64_t tap_recorded = r.tap->recorded.load(std::memory_order_relaxed);
    const std::uint64_t tap_dropped = r.tap->dropped();
    list.push_back({{"connection", r.connection},
                    {"channel", r.tap->channel},
                    {"encoding", r.tap->encoding},
                    {"recorded", tap_recorded},
                    {"dropped", tap_dropped}});
    if (out.contains("connections")) {
      for (auto& c : out["connections"]) {
        if (c.value("name", "") == r.connection) {
          c["recorded"] = tap_recorded;
          c["record_dropped"] = tap_dropped;
        }
      }
    }
  }
  out["recording"] = {{"file", file_},
                      {"events", events_.load(std::memory_order_relaxed)},
                      {"record_dropped", dropped},
                      {"connections", std::move(list)}};
}

}  // namespace polyport::daemon
