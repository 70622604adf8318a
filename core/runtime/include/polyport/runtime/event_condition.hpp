// The condition of an event connection (SmartSoft's event with conditions): the server's
// state samples are tested on the forwarding path, and the client's event input gets one only
// when every field holds and the client's activation is active.
//
// Threads: admits() runs on the source's writer thread (the forwarding path: no lock, no
// allocation). activate() / deactivate() run on the client's thread or the control thread;
// they never block the writer. The activation (active, mode, thresholds) is published as a
// sequence-locked block of atomics allocated once: the writer reads a whole copy, or, when an
// activation was being written during its read, keeps the last whole one (it never waits).
// A single-shot activation ends on the writer's side by recording the generation it fired
// for, so that an activation made meanwhile is never lost.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/result.hpp"
#include "polyport/base/status.hpp"
#include "polyport/profile/condition_spec.hpp"
#include "polyport/runtime/pi_mutex.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

class DataInPort;

// A number in a flat sample, as a double: what deadbands and conditions compare.
double flat_number(const std::byte* flat, std::uint32_t offset, TypeKind kind) noexcept;

// One comparison, resolved in the source type's flat layout.
struct ConditionField {
  std::uint32_t offset = 0;
  TypeKind kind = TypeKind::float64;
  ConditionOp op = ConditionOp::lt;
  double value = 0.0;  // the profile's threshold
  std::string param;   // the activation parameter that overrides it; empty: none
  std::string path;    // as the profile names it, for check and stats
};

// A parameter of an activation: the threshold of every field whose `param` is `name`.
struct ConditionParameter {
  std::string_view name;
  double value = 0.0;
};

struct ConditionCounters {
  std::atomic<std::uint64_t> tested{0};       // state samples tested while active
  std::atomic<std::uint64_t> fired{0};        // ... for which the condition held: delivered
  std::atomic<std::uint64_t> suppressed{0};   // ... for which it did not
  std::atomic<std::uint64_t> inactive{0};     // state samples that came while not activated
  std::atomic<std::uint64_t> activations{0};  // activate() calls accepted (the profile's initial one too)
};

class EventCondition {
 public:
  // The profile's activation: `active` with `mode` and each field's own value.
  EventCondition(std::vector<ConditionField> fields, EventMode mode, bool active);
  EventCondition(const EventCondition&) = delete;
  EventCondition& operator=(const EventCondition&) = delete;

  // Writer thread. Whether this state sample (the source's flat sample) goes to the client;
  // counts it. A single-shot activation is spent by the sample it admits.
  bool admits(const std::byte* flat) noexcept;

  // Client or control thread (activations of one condition are serialised among themselves,
  // never with the writer). Parameters not named keep the profile's value; a name that no
  // field uses is refused with Status::error and changes nothing.
  Status activate(EventMode mode, std::span<const ConditionParameter> parameters = {}) noexcept;
  void deactivate() noexcept;
  // Whether every parameter names a field's `param`; whether one does.
  bool knows(std::span<const ConditionParameter> parameters) const noexcept;
  bool uses(std::string_view parameter) const noexcept;
  // activate() without the check: parameters that no field uses are passed over (a port
  // whose connections have different conditions gives each the same list).
  void apply(EventMode mode, std::span<const ConditionParameter> parameters) noexcept;

  // What an observer sees now (stats): active and not yet spent.
  bool active() const noexcept;
  EventMode mode() const noexcept;
  // The thresholds in force, in field order (stats).
  std::vector<double> thresholds() const;
  const std::vector<ConditionField>& fields() const noexcept { return fields_; }
  const ConditionCounters& counters() const noexcept { return counters_; }

 private:
  struct Snapshot {
    bool active;
    EventMode mode;
    std::uint64_t generation;
  };
  // Reads the activation into `snapshot` and `thresholds` (room for every field); false when
  // an activation was being written meanwhile (what was read is then not to be used).
  bool read(Snapshot& snapshot, double* thresholds) const noexcept;
  void publish(bool active, EventMode mode, const double* thresholds) noexcept;

  std::vector<ConditionField> fields_;
  // The published activation: a sequence number (odd while written), then its parts.
  std::atomic<std::uint64_t> sequence_{0};
  std::atomic<bool> active_{false};
  std::atomic<EventMode> mode_{EventMode::continuous};
  std::atomic<std::uint64_t> generation_{0};  // one per activation
  std::unique_ptr<std::atomic<double>[]> thresholds_;
  // Writer thread: a read in progress, and the last activation read whole.
  std::unique_ptr<double[]> scratch_;
  Snapshot last_{};
  std::unique_ptr<double[]> last_thresholds_;
  // The generation a single-shot activation fired for (written by the writer only).
  std::atomic<std::uint64_t> spent_{~std::uint64_t{0}};
  // Activations among themselves (the client's thread, perhaps real-time, and the control
  // thread for polyportctl): priority inheritance, so an ordinary holder cannot keep a
  // real-time client waiting. The writer never takes it.
  PiMutex activating_;
  ConditionCounters counters_;
};

// Builds a connection's condition from the profile: each field resolved in `source_type`.
Result<std::unique_ptr<EventCondition>> make_event_condition(const Type& source_type, const ConditionSpec& spec);

// Every condition on the connections into `port` (an event input): activated with the same
// mode and parameters. not_connected when none of them has a condition; error when a
// parameter names no field (nothing changed then).
Status activate_conditions(DataInPort& port, EventMode mode, std::span<const ConditionParameter> parameters) noexcept;
Status deactivate_conditions(DataInPort& port) noexcept;

}  // namespace polyport
