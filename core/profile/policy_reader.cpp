// A data connection's policies beyond its queue:
//  - <watchdog>: its times, the upstream port whose silence also trips it, and the safe value
//    it hands the target instead of stale samples;
//  - <rate_limit per_second>: at most that many samples a second, newest wins;
//  - <deadband>: only samples where a <field name threshold> moved by more than its threshold.
//
//   <watchdog deadline_ms="20" max_age_ms="50">
//     <upstream component_name="Joystick" port_name="reference"/>
//     <safe_value><field target="left_v" value="0"/></safe_value>
//   </watchdog>
//   <rate_limit per_second="20"/>
//   <deadband><field name="speed_mps" threshold="0.05"/></deadband>

#include "loader.hpp"

namespace polyport::detail {

namespace {

constexpr double kMaxWatchdogMs = 86400000.0;  // a day, as the DDS deadlines
const std::string kWatchdogMsExpected = "expected milliseconds, a decimal above 0 and at most 86400000";

// A time attribute in milliseconds (decimals allowed: "2.5"), in nanoseconds; 0 when absent.
std::int64_t read_ms(const Reporter& report, pugi::xml_node element, const char* name, bool& ok) {
  const pugi::xml_attribute attribute = element.attribute(name);
  if (!attribute) return 0;
  const std::string text(trim(attribute.value()));
  const auto ms = parse_decimal(text);
  if (!ms || *ms <= 0.0 || *ms > kMaxWatchdogMs) {
    report.error_attribute(element, name, "bad " + std::string(name) + " " + in_quotes(text) + ": " + kWatchdogMsExpected);
    ok = false;
    return 0;
  }
  return static_cast<std::int64_t>(std::llround(*ms * 1e6));
}

constexpr double kMaxRatePerSecond = 1e6;
constexpr const char* kWatchdogEventType = "polyport::WatchdogEvent";

bool is_number(TypeKind kind) {
  switch (kind) {
    case TypeKind::int8: case TypeKind::uint8: case TypeKind::int16: case TypeKind::uint16:
    case TypeKind::int32: case TypeKind::uint32: case TypeKind::int64: case TypeKind::uint64:
    case TypeKind::float32: case TypeKind::float64: case TypeKind::octet:
      return true;
    default:
      return false;
  }
}

}  // namespace

void Loader::read_rate_policies(const Reporter& report, const Children& children, ConnectionSpec& spec) {
  if (const pugi::xml_node limit = children.one("rate_limit")) {
    const pugi::xml_attribute attribute = limit.attribute("per_second");
    const std::string text(trim(attribute.value()));
    const auto rate = parse_decimal(text);
    if (!attribute) {
      report.error(limit, "missing attribute 'per_second'");
    } else if (!rate || *rate <= 0.0 || *rate > kMaxRatePerSecond) {
      report.error_attribute(limit, "per_second",
                             "bad per_second " + in_quotes(text) + ": expected a decimal above 0 and at most 1000000");
    } else {
      spec.rate_limit_per_second = *rate;
    }
  }
  const pugi::xml_node deadband_node = children.one("deadband");
  if (!deadband_node) return;
  const Children fields = scan(report, deadband_node, kDeadbandRules);
  if (fields.all("field").empty()) report.error(deadband_node, "a deadband needs at least one <field name threshold>");
  for (const pugi::xml_node deadband : fields.all("field")) {
    DeadbandSpec band;
    band.where = report.xml().at(deadband);
    band.element_path = element_path(deadband);
    band.field = std::string(trim(deadband.attribute("name").value()));
    bool ok = true;
    if (band.field.empty()) {
      report.error(deadband, "missing attribute 'name' (the number whose change lets a sample pass)");
      ok = false;
    }
    const pugi::xml_attribute threshold = deadband.attribute("threshold");
    const std::string text(trim(threshold.value()));
    const auto value = parse_number(text);
    if (!threshold) {
      report.error(deadband, "missing attribute 'threshold'");
      ok = false;
    } else if (!value || *value < 0.0) {
      report.error_attribute(deadband, "threshold",
                             "bad threshold " + in_quotes(text) + ": expected a number of 0 or more");
      ok = false;
    } else {
      band.threshold = *value;
    }
    if (ok) spec.deadbands.push_back(std::move(band));
  }
}

void Loader::check_rate_policies(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec,
                                 const PortSpec* source) {
  if (spec.kind != PortKind::data) {
    for (const char* name : {"rate_limit", "deadband"}) {
      for (const pugi::xml_node element : node.children(name)) {
        report.error(element, "a " + std::string(name == std::string("deadband") ? "deadband" : "rate limit") +
                                  " applies only to data connections");
      }
    }
    spec.rate_limit_per_second.reset();
    spec.deadbands.clear();
    return;
  }
  if (spec.deadbands.empty() || source == nullptr || source->data_type.empty()) return;
  const Type* type = types_.find(source->data_type);
  if (type == nullptr) return;  // reported at the port
  const std::string source_name = spec.source.component + "." + spec.source.port;
  for (const DeadbandSpec& band : spec.deadbands) {
    const FieldPathResult found = find_field_path(*type, band.field);
    std::string problem;
    if (found.bad_syntax) {
      problem = "bad field " + in_quotes(band.field) + " (expected names and [index], e.g. a.b[1].c)";
    } else if (!found.place) {
      problem = "field " + in_quotes(band.field) + " not found in " + in_quotes(type->name) + " of " + source_name +
                " (" + found.why + ")";
    } else if (!is_number(found.place->type->kind)) {
      problem = "a deadband compares numbers; " + in_quotes(band.field) + " of " + source_name + " is " +
                in_quotes(found.place->type->name);
    }
    if (!problem.empty()) diagnostics_.error(band.where, band.element_path, problem);
  }
}

std::optional<WatchdogSpec> Loader::read_watchdog(const Reporter& report, pugi::xml_node element) {
  WatchdogSpec spec;
  spec.where = report.xml().at(element);
  bool ok = true;
  if (!element.attribute("deadline_ms")) {
    report.error(element, "missing attribute 'deadline_ms' (how long the source may be silent)");
    ok = false;
  }
  spec.deadline_ns = read_ms(report, element, "deadline_ms", ok);
  spec.max_age_ns = read_ms(report, element, "max_age_ms", ok);

  const Children children = scan(report, element, kWatchdogRules);
  if (const pugi::xml_node upstream = children.one("upstream")) {
    ConnectionEnd end;
    read_end(report, element, upstream, "upstream", end);
    spec.upstream = std::move(end);
  }
  if (const pugi::xml_node event = children.one("event")) {
    ConnectionEnd end;
    read_end(report, element, event, "event", end);
    spec.event = std::move(end);
  }
  spec.safe_value.by_name = false;  // fields no rule sets are zero
  if (const pugi::xml_node safe = children.one("safe_value")) {
    spec.safe_value.where = report.xml().at(safe);
    spec.safe_value.element_path = element_path(safe);
    const Children fields = scan(report, safe, kMappingRules);
    for (const pugi::xml_node field : fields.all("field")) {
      auto rule = read_rule(report, field);
      if (!rule) {
        ok = false;
        continue;
      }
      if (rule->kind != MappingRule::Kind::constant) {
        report.error(field, "a safe value sets constants only: give 'value', not 'source' or a transform");
        ok = false;
        continue;
      }
      spec.safe_value.rules.push_back(std::move(*rule));
    }
  } else {
    spec.safe_value.where = spec.where;
    spec.safe_value.element_path = element_path(element);
  }
  if (!ok) return std::nullopt;
  return spec;
}

void Loader::check_watchdog(const Reporter& report, const ApplicationProfile& app, pugi::xml_node node,
                            ConnectionSpec& spec, const PortSpec* target) {
  if (!spec.watchdog) return;
  const pugi::xml_node element = node.child("watchdog");
  if (spec.kind != PortKind::data) {
    report.error(element, "a watchdog applies only to data connections");
    spec.watchdog.reset();
    return;
  }
  WatchdogSpec& watchdog = *spec.watchdog;
  if (watchdog.max_age_ns > 0 && watchdog.max_age_ns < watchdog.deadline_ns) {
    report.warning_attribute(element, "max_age_ms",
                             "max_age_ms is shorter than deadline_ms: every sample that arrives late "
                             "enough to be within the deadline is replaced anyway");
  }
  if (watchdog.upstream) {
    const pugi::xml_node upstream_node = element.child("upstream");
    const ResolvedEnd upstream = resolve(report, app, upstream_node, *watchdog.upstream);
    if (upstream.checkable &&
        (upstream.port->kind != PortKind::data || upstream.port->direction != PortDirection::output)) {
      report.error(upstream_node, watchdog.upstream->component + "." + watchdog.upstream->port + " is " +
                                      port_noun(*upstream.port) + " (" +
                                      std::string(to_string(upstream.port->direction)) +
                                      "); a watchdog's upstream must be an output data port");
    }
  }
  if (watchdog.event) {
    const pugi::xml_node event_node = element.child("event");
    const ResolvedEnd event = resolve(report, app, event_node, *watchdog.event);
    const std::string name = watchdog.event->component + "." + watchdog.event->port;
    if (event.checkable) {
      const PortSpec& port = *event.port;
      if (port.kind == PortKind::service || port.direction != PortDirection::input) {
        report.error(event_node, name + " is " + port_noun(port) + " (" + std::string(to_string(port.direction)) +
                                     "); a watchdog's events go to an input event or data port");
      } else if (!types_.find(kWatchdogEventType)) {
        report.error(event_node, "the type " + std::string(kWatchdogEventType) +
                                     " is not loaded: add config/types/watchdog_event.idl to the profile's <types>");
      } else if (!same_type(port.data_type, kWatchdogEventType)) {
        report.error(event_node, name + " carries " + in_quotes(port.data_type) + "; a watchdog's events are " +
                                     in_quotes(kWatchdogEventType));
      }
    }
  }
  if (target == nullptr || target->data_type.empty()) return;  // reported at the port
  const Type* type = types_.find(target->data_type);
  if (type == nullptr) return;  // reported at the port
  // Rules' problems are reported at their <field>; a rule-less problem (none expected: the
  // program reads nothing of its source) at the <safe_value>.
  watchdog.safe_program = MappingProgram::compile(*type, *type, watchdog.safe_value, diagnostics_);
}

}  // namespace polyport::detail
