// The small status codes of the forwarding and call paths. Each non-ok value feeds a
// per-connection or per-port counter; none of them allocates or throws.
#pragma once

#include <cstdint>
#include <string_view>

namespace polyport {

enum class Status : std::uint8_t {
  ok,                 // done (a read: new data)
  old_data,           // a read of a `data` port whose value was already read once
  no_data,            // a read with nothing to read
  not_connected,      // a required service (or port) with nothing behind it
  queue_full,         // a `buffer` connection or a provider's request queue was full
  timeout,            // a call's reply did not come in time
  too_many_calls,     // the cap on calls in flight was reached
  unknown_operation,  // the provider has no such operation
  bad_size,           // a payload of the wrong size for the port's or operation's type
  not_active,         // the provider is not running
  error,              // the provider (or a foreign peer) reported an error
  // The caller's side gave up without waiting: its blocking mode is off (a component being
  // stopped), or the call was discarded. Never sent in a reply header (codes there end at
  // error); it comes after error so that those codes keep their values.
  cancelled,
};

constexpr std::string_view to_string(Status status) noexcept {
  switch (status) {
    case Status::ok: return "ok";
    case Status::old_data: return "old_data";
    case Status::no_data: return "no_data";
    case Status::not_connected: return "not_connected";
    case Status::queue_full: return "queue_full";
    case Status::timeout: return "timeout";
    case Status::too_many_calls: return "too_many_calls";
    case Status::unknown_operation: return "unknown_operation";
    case Status::bad_size: return "bad_size";
    case Status::not_active: return "not_active";
    case Status::error: return "error";
    case Status::cancelled: return "cancelled";
  }
  return "?";
}

}  // namespace polyport
