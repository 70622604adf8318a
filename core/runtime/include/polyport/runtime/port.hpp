// Ports of the application graph and the data path through them.
//
// Hot path (writer's thread): DataOutPort::write stamps t_in once, then for each attached
// Connection calls Connection::deliver, which either hands the bytes to the input port's
// sink (push mode: adaptors forwarding into a foreign model, on this same thread) or copies
// them into the connection's lock-free buffer (pull mode: a component reads on its own
// period). No allocation, no lock, no logging.
// Ownership: a Component owns its ports; the Engine owns connections. The connection list
// of a port is an immutable snapshot swapped atomically by the control thread; replaced
// snapshots are kept until the port dies, so a writer never reads freed memory.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "polyport/base/clock.hpp"
#include "polyport/profile/profile.hpp"
#include "polyport/runtime/sample_buffer.hpp"
#include "polyport/base/status.hpp"

namespace polyport {

struct Type;
class Codec;
class Component;
class Connection;
enum class WireFormat : std::uint8_t;

class Port {
 public:
  Port(Component& owner, std::string name, PortKind kind, PortDirection direction, const Type* type);
  Port(const Port&) = delete;
  Port& operator=(const Port&) = delete;
  virtual ~Port();

  const std::string& name() const noexcept { return name_; }
  PortKind kind() const noexcept { return kind_; }
  PortDirection direction() const noexcept { return direction_; }
  const Type* type() const noexcept { return type_; }  // null: no payload (events, services)
  Component& owner() const noexcept { return owner_; }
  std::string full_name() const;  // "Component.port"

  // How samples on this port are encoded: flat (in-process) unless the adaptor of a foreign
  // model says otherwise and gives the codec between its format and the flat layout.
  // Set before wiring.
  WireFormat wire_format() const noexcept { return format_; }
  const Codec* codec() const noexcept { return codec_; }
  void set_wire_format(WireFormat format, const Codec* codec) noexcept {
    format_ = format;
    codec_ = codec;
  }

 private:
  Component& owner_;
  std::string name_;
  PortKind kind_;
  PortDirection direction_;
  const Type* type_;
  WireFormat format_{};  // flat
  const Codec* codec_ = nullptr;
};

// Told when a port's connection list changes (control thread): a push server (push_server.hpp)
// primes a new subscriber between adding() and added(), while the list is published.
class ConnectionSetObserver {
 public:
  virtual ~ConnectionSetObserver() = default;
  virtual void adding(Connection& connection) noexcept = 0;
  virtual void added(Connection& connection) noexcept = 0;
  virtual void removed(Connection& connection) noexcept = 0;
};

// The connections of one port: an immutable list, replaced whole when the wiring changes.
// Writers and readers load the current list without a lock; the control thread publishes
// a new one. Old lists stay alive until the port dies, so a reader never sees freed memory.
class ConnectionSet {
 public:
  // A port's few connections sit in the list's own cache line; more spill to the heap.
  struct alignas(64) List {
    static constexpr std::size_t kInline = 5;
    std::size_t size = 0;
    Connection* const* items = nullptr;  // inline_ or spill_
    Connection* inline_[kInline] = {};
    std::unique_ptr<Connection*[]> spill_;
    Connection* const* begin() const noexcept { return items; }
    Connection* const* end() const noexcept { return items + size; }
  };

  ConnectionSet();
  const List& current() const noexcept { return *current_.load(std::memory_order_acquire); }
  std::size_t size() const noexcept { return current().size; }

  // Control thread only.
  void add(Connection& connection);
  void remove(Connection& connection);
  void set_observer(ConnectionSetObserver* observer) noexcept { observer_ = observer; }

 private:
  void publish(const std::vector<Connection*>& items);

  std::atomic<const List*> current_{nullptr};
  std::vector<std::unique_ptr<List>> retained_;
  ConnectionSetObserver* observer_ = nullptr;
};

class PushServer;

// Aligned so that what write() touches (below Port's fields) shares one cache line.
class alignas(64) DataOutPort final : public Port {
 public:
  DataOutPort(Component& owner, std::string name, PortKind kind, const Type* type,
              std::uint32_t max_sample_bytes);
  ~DataOutPort() override;

  // Forwards one sample to every connection. Returns not_connected when there is none
  // (the sample is counted and dropped). Safe to call from one thread at a time. A push
  // port goes through its server first (not_active while it is stopped).
  [[gnu::hot]] Status write(const void* data, std::uint32_t size, MonoTime t_source = {}) noexcept;
  // write() without the push server's part: the push server's own way out.
  [[gnu::hot]] Status forward(const void* data, std::uint32_t size, MonoTime t_source) noexcept;
  // Push newest / push timed (push_server.hpp); null for a plain port. Set before wiring.
  PushServer* push() const noexcept { return push_.get(); }
  void set_push(std::unique_ptr<PushServer> push);

  std::uint32_t max_sample_bytes() const noexcept { return max_sample_bytes_; }
  std::uint64_t written() const noexcept { return written_.load(std::memory_order_relaxed); }
  std::uint64_t unconnected_writes() const noexcept { return unconnected_.load(std::memory_order_relaxed); }
  // When write() was last called (connected or not); 0 before the first. Watchdogs read it.
  MonoTime last_write() const noexcept { return MonoTime{last_write_.load(std::memory_order_relaxed)}; }
  ConnectionSet& connections() noexcept { return connections_; }

 private:
  // Every write: in one cache line with Port's codec (the push server, the counters, the
  // connection list's pointer first in ConnectionSet).
  std::uint32_t max_sample_bytes_;
  std::atomic<std::uint64_t> written_{0};
  std::atomic<std::uint64_t> unconnected_{0};
  std::atomic<std::int64_t> last_write_{0};
  std::unique_ptr<PushServer> push_;
  ConnectionSet connections_;
};

// Where a push-mode input port delivers, on the writer's thread.
class SampleSink {
 public:
  virtual ~SampleSink() = default;
  virtual Status on_sample(const std::byte* data, const SampleMeta& meta) noexcept = 0;
};

class DataInPort final : public Port {
 public:
  DataInPort(Component& owner, std::string name, PortKind kind, const Type* type,
             std::uint32_t max_sample_bytes, QueuePolicy policy, std::uint32_t depth);

  // Pull mode: takes the next sample from the port's connections. ok = new data,
  // old_data = the `data` value was read before, no_data = nothing yet. Reader thread only.
  Status read(void* dst, std::uint32_t capacity, SampleMeta* meta = nullptr) noexcept;

  // Push mode: samples go straight to the sink on the writer's thread. Set before wiring.
  void set_sink(SampleSink* sink) noexcept { sink_ = sink; }
  SampleSink* sink() const noexcept { return sink_; }

  std::uint32_t max_sample_bytes() const noexcept { return max_sample_bytes_; }
  QueuePolicy policy() const noexcept { return policy_; }
  std::uint32_t depth() const noexcept { return depth_; }
  ConnectionSet& connections() noexcept { return connections_; }

 private:
  std::uint32_t max_sample_bytes_;
  QueuePolicy policy_;
  std::uint32_t depth_;
  SampleSink* sink_ = nullptr;
  ConnectionSet connections_;
  std::size_t next_ = 0;  // round robin over connections, reader thread only
};

}  // namespace polyport
