// A data connection's <watchdog>: its times, the upstream port whose silence also trips it,
// and the safe value it hands the target instead of stale samples.
//
//   <watchdog deadline_ms="20" max_age_ms="50">
//     <upstream component_name="Joystick" port_name="reference"/>
//     <safe_value><field target="left_v" value="0"/></safe_value>
//   </watchdog>

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

}  // namespace

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
  if (target == nullptr || target->data_type.empty()) return;  // reported at the port
  const Type* type = types_.find(target->data_type);
  if (type == nullptr) return;  // reported at the port
  // Rules' problems are reported at their <field>; a rule-less problem (none expected: the
  // program reads nothing of its source) at the <safe_value>.
  watchdog.safe_program = MappingProgram::compile(*type, *type, watchdog.safe_value, diagnostics_);
}

}  // namespace polyport::detail
