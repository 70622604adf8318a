// SmartSoft's push patterns in the profiles:
//  - <push pattern="newest"/> in an output <data_port>: every new value reaches every
//    subscriber, and a subscriber that comes later gets the latest at once;
//  - <push pattern="timed" cycle_ms="10"/>: the port publishes once per base cycle (an
//    in-process periodic component's base cycle is a whole multiple of its period);
//  - <subscription every="3"/> in a <port_connection> from a push timed port: this
//    subscriber takes every 3rd cycle.

#include "loader.hpp"

namespace polyport::detail {

namespace {

constexpr Spelling<PushPattern> kPushPatterns[] = {
    {"newest", PushPattern::newest},
    {"timed", PushPattern::timed},
};
constexpr double kMaxCycleMs = 86400000.0;  // a day, as the watchdogs' times

std::string ms_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace

void Loader::read_push(const Reporter& report, pugi::xml_node element, PortSpec& port, const ComponentProfile& profile) {
  if (port.kind != PortKind::data) {
    report.error(element, "<push> applies only to data ports (a push server is an output data port)");
    return;
  }
  if (port.direction == PortDirection::input) {
    report.error(element, "<push> applies only to output data ports: the server publishes, its subscribers "
                          "are the connections from it");
    return;
  }
  PushSpec push;
  push.where = report.xml().at(element);
  const pugi::xml_attribute pattern = element.attribute("pattern");
  const std::string pattern_text(trim(pattern.value()));
  if (!pattern) {
    report.error(element, "missing attribute 'pattern' (newest or timed)");
    return;
  }
  const auto found = lookup(kPushPatterns, pattern_text);
  if (!found) {
    report.error_attribute(element, "pattern", "bad pattern " + in_quotes(pattern_text) + ": expected newest or timed");
    return;
  }
  push.pattern = *found;
  const pugi::xml_attribute cycle = element.attribute("cycle_ms");
  if (push.pattern == PushPattern::newest) {
    if (cycle) {
      report.error_attribute(element, "cycle_ms", "cycle_ms applies only to push timed (pattern=\"timed\"); push "
                                                  "newest publishes whenever a new value comes");
      return;
    }
    port.push = push;
    return;
  }
  if (!cycle) {
    report.error(element, "missing attribute 'cycle_ms' (a push timed port's base cycle, which subscribers "
                          "take multiples of)");
    return;
  }
  const std::string text(trim(cycle.value()));
  const auto ms = parse_decimal(text);
  if (!ms || *ms <= 0.0 || *ms > kMaxCycleMs) {
    report.error_attribute(element, "cycle_ms", "bad cycle_ms " + in_quotes(text) +
                                                    ": expected milliseconds, a decimal above 0 and at most 86400000");
    return;
  }
  push.cycle_ms = *ms;
  // An in-process periodic component writes once per period at most: its base cycle is a
  // whole number of periods (the port sends the first write of each base cycle).
  const double period = profile.execution.period_ms;
  if (profile.model == "inproc" && is_periodic(profile.execution.type) && period > 0.0) {
    const double ratio = *ms / period;
    if (std::llround(ratio) < 1 || std::abs(ratio - static_cast<double>(std::llround(ratio))) > 1e-9 * ratio) {
      report.error_attribute(element, "cycle_ms",
                             "a push timed port's base cycle is a whole multiple of its component's period (" +
                                 ms_text(period) + " ms): cycle_ms " + ms_text(*ms) + " is not; e.g. " +
                                 ms_text(period) + ", " + ms_text(2 * period) + " or " + ms_text(3 * period));
      return;
    }
  }
  port.push = push;
}

void Loader::read_subscription(const Reporter& report, const Children& children, ConnectionSpec& spec) {
  const pugi::xml_node subscription = children.one("subscription");
  if (!subscription) return;
  const pugi::xml_attribute every = subscription.attribute("every");
  if (!every) {
    report.error(subscription, "missing attribute 'every' (this subscriber takes every Nth cycle of the server)");
    return;
  }
  const std::string text(trim(every.value()));
  const auto value = parse_integer<std::uint32_t>(text);
  // A million cycles is beyond any use (at 1 ms, one sample in 17 minutes); the bound keeps a
  // typo from loading as a subscription that never delivers.
  if (!value || *value == 0 || *value > 1'000'000) {
    report.error_attribute(subscription, "every",
                           "bad every " + in_quotes(text) +
                               ": expected a whole number of the server's base cycles, from 1 to 1000000");
    return;
  }
  spec.subscription_every = *value;
}

void Loader::check_subscription(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                                const PortSpec* source) {
  if (!spec.subscription_every) return;
  const pugi::xml_node element = node.child("subscription");
  if (spec.kind != PortKind::data) {
    report.error(element, "a subscription applies only to data connections");
    spec.subscription_every.reset();
    return;
  }
  if (source == nullptr) return;  // reported at the end
  if (!source->push || source->push->pattern != PushPattern::timed) {
    report.error(element, spec.source.component + "." + spec.source.port +
                              " is not a push timed port: a subscription takes every Nth base cycle of an output "
                              "data port with <push pattern=\"timed\" cycle_ms=\"...\"/>");
    spec.subscription_every.reset();
  }
}

}  // namespace polyport::detail

namespace polyport {

std::string_view to_string(PushPattern pattern) noexcept {
  switch (pattern) {
    case PushPattern::newest: return "newest";
    case PushPattern::timed: return "timed";
  }
  return "unknown";
}

}  // namespace polyport
