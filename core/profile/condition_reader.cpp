// An event connection's <condition> (SmartSoft's event with conditions): the fields of the
// source's state that must all hold for the client's event input to get a sample, the mode
// of the activation and whether it is active from the start.
//
//   <port_connection port_type="event">
//     <source component_name="Battery" port_name="state"/>
//     <target component_name="Planner" port_name="battery_low"/>
//     <condition mode="single" active="true">
//       <field name="charge" op="lt" value="20" param="level"/>
//     </condition>
//   </port_connection>

#include "loader.hpp"

namespace polyport::detail {

namespace {

constexpr Spelling<ConditionOp> kConditionOps[] = {
    {"lt", ConditionOp::lt}, {"le", ConditionOp::le}, {"gt", ConditionOp::gt},
    {"ge", ConditionOp::ge}, {"eq", ConditionOp::eq}, {"ne", ConditionOp::ne},
};
constexpr Spelling<EventMode> kEventModes[] = {
    {"single", EventMode::single},
    {"continuous", EventMode::continuous},
};

}  // namespace

std::optional<ConditionSpec> Loader::read_condition(const Reporter& report, pugi::xml_node element) {
  ConditionSpec spec;
  spec.where = report.xml().at(element);
  spec.element_path = element_path(element);
  if (const pugi::xml_attribute mode = element.attribute("mode")) {
    const std::string text(trim(mode.value()));
    if (const auto value = lookup(kEventModes, text)) {
      spec.mode = *value;
    } else {
      report.error_attribute(element, "mode", "bad mode " + in_quotes(text) + " (accepted: " + accepted(kEventModes) + ")");
    }
  }
  if (const pugi::xml_attribute active = element.attribute("active")) {
    const std::string text(trim(active.value()));
    if (const auto value = lookup(kBooleans, text)) {
      spec.active = *value;
    } else {
      report.error_attribute(element, "active", "bad active " + in_quotes(text) + " (accepted: " + accepted(kBooleans) + ")");
    }
  }
  const Children fields = scan(report, element, kConditionRules);
  if (fields.all("field").empty()) {
    report.error(element, "a condition needs at least one <field name op value>");
  }
  for (const pugi::xml_node node : fields.all("field")) {
    ConditionFieldSpec field;
    field.where = report.xml().at(node);
    field.element_path = element_path(node);
    field.field = std::string(trim(node.attribute("name").value()));
    bool field_ok = true;
    if (field.field.empty()) {
      report.error(node, "missing attribute 'name' (the number of the source's state to test)");
      field_ok = false;
    }
    const pugi::xml_attribute op = node.attribute("op");
    const std::string op_text(trim(op.value()));
    if (!op) {
      report.error(node, "missing attribute 'op' (accepted: " + accepted(kConditionOps) + ")");
      field_ok = false;
    } else if (const auto value = lookup(kConditionOps, op_text)) {
      field.op = *value;
    } else {
      report.error_attribute(node, "op", "bad op " + in_quotes(op_text) + " (accepted: " + accepted(kConditionOps) + ")");
      field_ok = false;
    }
    const pugi::xml_attribute value = node.attribute("value");
    const std::string value_text(trim(value.value()));
    const auto number = parse_number(value_text);
    if (!value) {
      report.error(node, "missing attribute 'value' (the threshold, also when an activation may give 'param')");
      field_ok = false;
    } else if (!number) {
      report.error_attribute(node, "value", "bad value " + in_quotes(value_text) + ": expected a number");
      field_ok = false;
    } else {
      field.value = *number;
    }
    if (const pugi::xml_attribute param = node.attribute("param")) {
      field.param = std::string(trim(param.value()));
      if (field.param.empty()) {
        report.error_attribute(node, "param", "empty attribute 'param'");
        field_ok = false;
      }
    }
    if (field_ok) spec.fields.push_back(std::move(field));
  }
  // With what could be read, so that the check still reports its fields' problems against
  // the source's type (nothing runs: the errors are counted already).
  return spec;
}

void Loader::check_condition(const Reporter& report, pugi::xml_node node, ConnectionSpec& spec, const PortSpec* source) {
  const pugi::xml_node element = node.child("condition");
  if (!element) return;
  if (spec.kind != PortKind::event) {
    report.error(element, "a condition applies only to event connections (port_type=\"event\"): the source's state, "
                          "tested for the target's event input");
    spec.condition.reset();
    return;
  }
  if (!spec.condition || source == nullptr) return;  // reported already
  const std::string source_name = spec.source.component + "." + spec.source.port;
  if (source->data_type.empty()) {
    report.error(element, "a condition tests the source's state, but " + source_name + " carries no data type");
    return;
  }
  const Type* type = types_.find(source->data_type);
  if (type == nullptr) return;  // reported at the port
  for (const ConditionFieldSpec& field : spec.condition->fields) {
    const FieldPathResult found = find_field_path(*type, field.field);
    std::string problem;
    if (found.bad_syntax) {
      problem = "bad field " + in_quotes(field.field) + " (expected names and [index], e.g. a.b[1].c)";
    } else if (!found.place) {
      problem = "field " + in_quotes(field.field) + " not found in " + in_quotes(type->name) + " of " + source_name +
                " (" + found.why + ")";
    } else if (!is_number(found.place->type->kind)) {
      problem = "a condition compares numbers; " + in_quotes(field.field) + " of " + source_name + " is " +
                in_quotes(found.place->type->name);
    }
    if (!problem.empty()) diagnostics_.error(field.where, field.element_path, problem);
  }
}

}  // namespace polyport::detail
