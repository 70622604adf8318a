// Components of the query pattern's tests (tests/query): SmartSoft's query client calls
// (request / receive / receive_wait, query without a timeout) and the blocking mode.
#include <cstdint>
#include <string>

#include "polyport/runtime/component_api.hpp"

namespace polyport::test {

// tests/dds_peers/peer.idl's (and tests/lcm_e2e/lcm/calc.lcm's) add payloads.
struct PeerAddArgs {
  double a;
  double b;
};
struct PeerAddResult {
  double sum;
};
// tests/data/query/query.idl's query::Outcome: how one receive ended.
struct Outcome {
  std::int32_t n;        // the call's number: add(n, 0.5)
  std::int32_t status;   // polyport's Status code
  double sum;            // the reply's sum when status is ok
  std::int32_t not_yet;  // receives of the call that found no reply yet (mode poll)
};

// Calls peer `add` (n, 0.5), n = 1, 2, ..., one call at a time, and publishes how each ended
// on `outcome`. Its `mode` property says how it waits:
//   wait   request, then receive_wait: blocks until the reply comes or the blocking mode goes
//          off (a call that ended otherwise is discarded)
//   query  query without a timeout (the same, synchronously)
//   poll   request, then one receive that does not wait per cycle (no_data: not yet), until
//          the reply is there; every receive is published
// While its blocking mode is off (it is being stopped) it starts no call.
class QueryWaiter final : public ComponentBase {
 public:
  ReturnCode onInitialize() override {
    const std::string mode = property("mode", "wait");
    if (mode != "wait" && mode != "query" && mode != "poll") return ReturnCode::bad_parameter;
    mode_ = mode;
    return ReturnCode::ok;
  }
  ReturnCode onExecute() override {
    // Stopping (the blocking mode is off): no new call, as a component rushing to its stop.
    if (!blocking()) return ReturnCode::ok;
    if (mode_ == "poll") return poll();
    ++n_;
    PeerAddResult result{};
    Status status = Status::ok;
    if (mode_ == "query") {
      status = calc_.query("add", PeerAddArgs{static_cast<double>(n_), 0.5}, result);
    } else {
      CallHandle handle = calc_.request("add", PeerAddArgs{static_cast<double>(n_), 0.5});
      status = handle ? calc_.receive_wait(handle, result) : handle.status;
      if (status != Status::ok) calc_.discard(handle);
    }
    outcome_.write(Outcome{n_, static_cast<std::int32_t>(status), result.sum, 0});
    return ReturnCode::ok;
  }
  ReturnCode onDeactivated() override {
    calc_.discard(pending_);
    return ReturnCode::ok;
  }

 private:
  ReturnCode poll() {
    if (!pending_) {
      ++n_;
      not_yet_ = 0;
      pending_ = calc_.request("add", PeerAddArgs{static_cast<double>(n_), 0.5});
      if (!pending_) {
        outcome_.write(Outcome{n_, static_cast<std::int32_t>(pending_.status), 0.0, 0});
        return ReturnCode::ok;
      }
    }
    PeerAddResult result{};
    const Status status = calc_.receive(pending_, result);
    if (status == Status::no_data) ++not_yet_;
    outcome_.write(Outcome{n_, static_cast<std::int32_t>(status), result.sum, not_yet_});
    return ReturnCode::ok;
  }

  RequiredService calc_{*this, "calc"};
  OutPort<Outcome> outcome_{*this, "outcome"};
  std::string mode_ = "wait";
  CallHandle pending_;
  std::int32_t n_ = 0;
  std::int32_t not_yet_ = 0;
};

POLYPORT_COMPONENTS(POLYPORT_COMPONENT(QueryWaiter))

}  // namespace polyport::test
