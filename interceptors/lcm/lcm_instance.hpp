// One LCM instance (lcm_t) per provider URL, shared by every LCM proxy of the daemon that
// names that URL.
//
// Threads: the model's one LCM receive thread (an FdReactor, interceptors/common, named
// pp-lcm-recv) waits on every instance's notification descriptor (lcm_get_fileno) and calls
// lcm_handle when a message is ready, so subscription handlers run on it. One thread for all
// instances, as the SDK-only relay does: with one per instance polyport bridging two LCM
// networks paid ≈ 5 µs more per message at the median than that relay, ≈ 2 µs with one
// (docs/BENCHMARKS.md, LCM and CAN ping-pong). publish() runs on whichever thread forwards a
// sample (LCM serialises sends itself). Everything else runs on the control thread.
#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <string>

#include "fd_reactor.hpp"
#include "polyport/base/result.hpp"
#include "polyport/runtime/echo_table.hpp"
#include "polyport/runtime/thread_scheduling.hpp"
#include <nlohmann/json_fwd.hpp>

extern "C" {
struct _lcm_t;
typedef struct _lcm_t lcm_t;
struct _lcm_subscription_t;
typedef struct _lcm_subscription_t lcm_subscription_t;
struct _lcm_recv_buf_t;
typedef struct _lcm_recv_buf_t lcm_recv_buf_t;
}

namespace polyport::lcm {

// Receives the messages of one subscription on the receive thread.
class MessageHandler {
 public:
  virtual ~MessageHandler() = default;
  virtual void on_message(const void* data, std::uint32_t size) noexcept = 0;
};

// Loop prevention on one channel of one instance (polyport/runtime/echo_table.hpp): LCM has
// no notion of a sender, and a udpm subscriber receives the datagrams its own lcm_t sent. So
// when polyport both publishes and subscribes a channel on an instance, each publish records
// its message's fingerprint, with the number of polyport's subscriptions that will see it, and
// those subscriptions drop the echo. Shared by the interceptors of the instance.
struct ChannelEchoes {
  EchoTable table;
  std::atomic<std::uint32_t> subscribers{0};  // polyport's data subscriptions of the channel
  std::atomic<std::uint32_t> publishers{0};   // polyport's data publishers of the channel
};

class Instance final : public ReadableHandler {
 public:
  // The model's receive thread for LCM instances (pp-lcm-recv); one per daemon.
  static std::shared_ptr<FdReactor> create_reactor();
  // Nothing is opened before start(), so a profile is checked on any host.
  static std::shared_ptr<Instance> create(const std::string& url, std::shared_ptr<FdReactor> reactor);
  ~Instance() override;
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;

  // Opens the provider and sets up receiving (once; later calls return at once). A udpm URL
  // whose multicast group has no route, or whose datagrams do not come back to this host, is
  // an error that says which route to add.
  Result<void> start();
  // Hands the notification descriptor to the receive thread (once), after the caller's
  // subscriptions: what arrives before is queued by LCM, not dispatched to no one (a replayed
  // log would lose its first messages).
  Result<void> receive();

  // Subscribes to exactly `channel` (not a pattern). Control thread.
  Result<lcm_subscription_t*> subscribe(const std::string& channel, MessageHandler& handler);
  // After it returns, the handler is not running and is not called again.
  void unsubscribe(lcm_subscription_t* subscription) noexcept;

  // 0 on success (lcm_publish's result). Any thread, after start(); no allocation by polyport.
  int publish(const char* channel, const void* data, std::uint32_t size) noexcept;

  const std::string& url() const noexcept { return url_; }
  // A file:// provider has replayed its whole log (the receive thread stopped watching it).
  bool log_ended() const noexcept { return log_ended_.load(std::memory_order_acquire); }

  // The loop-prevention state of `channel` on this instance; lives as long as the instance.
  // Control thread.
  ChannelEchoes& echoes(const std::string& channel);

  // The scheduling a component asks for the receive thread (<lcm><receive_thread>); the
  // strongest of the requests of all the daemon's LCM components is applied when the thread
  // starts, or at once when it runs already (one warning when refused). Control thread.
  void want(const ThreadScheduling& scheduling) { reactor_->want(scheduling); }
  // {"asked": "SCHED_FIFO 60", "realtime": true, "pinned": false}; null when nothing was asked.
  nlohmann::json scheduling() const;

  // The receive thread: a message is queued, and this thread is the instance's only caller of
  // lcm_handle, so it returns at once. (lcm_handle_timeout would select on the same descriptor
  // again: one system call more per message, measured in the LCM benchmark.)
  void on_readable() noexcept override;

 private:
  Instance(std::string url, std::shared_ptr<FdReactor> reactor) : url_(std::move(url)), reactor_(std::move(reactor)) {}

  std::string url_;
  std::shared_ptr<FdReactor> reactor_;
  std::map<std::string, std::unique_ptr<ChannelEchoes>> echoes_;
  lcm_t* lcm_ = nullptr;
  int fileno_ = -1;
  bool receiving_ = false;  // the descriptor is with the receive thread
  bool reads_log_ = false;  // a file:// provider
  std::atomic<bool> log_ended_{false};
};

// Escapes `channel` for lcm_subscribe, which takes an anchored regular expression.
std::string channel_pattern(const std::string& channel);

// For a udpm:// URL, the multicast group and port it names (LCM's defaults when left out);
// empty group for other providers.
struct MulticastAddress {
  std::string group;
  int port = 0;
};
MulticastAddress multicast_address(const std::string& url);

}  // namespace polyport::lcm
