// An event with a condition (SmartSoft's event pattern): the <condition> of an event
// connection. The connection's source is the server's state; each sample it writes is one
// state change, tested against every <field> of the condition; the client's event input
// gets the sample only when all of them hold and its activation is active.
//
//   <condition mode="single" active="true">
//     <field name="battery" op="lt" value="20" param="level"/>
//   </condition>
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "polyport/base/diagnostics.hpp"

namespace polyport {

// How a field compares with its threshold: `field op threshold`.
enum class ConditionOp : std::uint8_t { lt, le, gt, ge, eq, ne };
// single: the activation ends with the first event it fires; continuous: it fires on every
// state change for which the condition holds, until deactivated.
enum class EventMode : std::uint8_t { single, continuous };

constexpr std::string_view to_string(ConditionOp op) noexcept {
  switch (op) {
    case ConditionOp::lt: return "lt";
    case ConditionOp::le: return "le";
    case ConditionOp::gt: return "gt";
    case ConditionOp::ge: return "ge";
    case ConditionOp::eq: return "eq";
    case ConditionOp::ne: return "ne";
  }
  return "?";
}

constexpr std::string_view to_string(EventMode mode) noexcept {
  return mode == EventMode::single ? "single" : "continuous";
}

constexpr std::optional<ConditionOp> condition_op(std::string_view text) noexcept {
  for (const ConditionOp op : {ConditionOp::lt, ConditionOp::le, ConditionOp::gt, ConditionOp::ge, ConditionOp::eq,
                               ConditionOp::ne}) {
    if (text == to_string(op)) return op;
  }
  return std::nullopt;
}

constexpr std::optional<EventMode> event_mode(std::string_view text) noexcept {
  if (text == "single") return EventMode::single;
  if (text == "continuous") return EventMode::continuous;
  return std::nullopt;
}

struct ConditionFieldSpec {
  std::string field;  // a number in the source port's type ("battery", "pose.x", "cells[2]")
  ConditionOp op = ConditionOp::lt;
  double value = 0.0;  // the threshold, unless an activation gives `param`
  std::string param;   // empty: the threshold is fixed
  SourceLocation where;
  std::string element_path;
};

struct ConditionSpec {
  EventMode mode = EventMode::continuous;
  bool active = true;  // activated from the start (with the profile's values)
  std::vector<ConditionFieldSpec> fields;  // all must hold
  SourceLocation where;
  std::string element_path;
};

}  // namespace polyport
