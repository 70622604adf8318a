// DBC frame layouts for `polyportd types`: id, length, cycle time and each signal's bits.
#include "type_printer.hpp"

#include <cstdint>
#include <cstdio>
#include <string>

#include "polyport/types/dbc.hpp"

namespace polyport::daemon {

void describe_dbc(const DbcMessage& message, nlohmann::json& out) {
  char id[16];
  std::snprintf(id, sizeof id, "0x%X", message.frame_id);
  nlohmann::json frame{{"id", id},
                       {"extended", message.extended},
                       {"length", message.length},
                       {"fd", message.fd},
                       {"cycle_time_ms", message.cycle_time_ms},
                       {"transmitter", message.transmitter}};
  for (const DbcSignal& s : message.signals) {
    nlohmann::json j{{"name", s.name},
                     {"start_bit", s.start_bit},
                     {"length", s.length},
                     {"byte_order", s.byte_order == DbcByteOrder::intel ? "intel" : "motorola"},
                     {"signed", s.is_signed},
                     {"factor", s.factor},
                     {"offset", s.offset},
                     {"unit", s.unit},
                     {"lsb_bit", s.lsb_bit},
                     {"msb_bit", s.msb_bit}};
    if (s.float_kind != DbcFloatKind::none) j["float"] = s.float_kind == DbcFloatKind::float32 ? "float32" : "float64";
    if (s.has_range()) j["range"] = {s.minimum, s.maximum};
    if (s.is_switch()) j["multiplexer"] = true;
    if (s.mux_role == DbcMuxRole::multiplexed && s.mux_parent >= 0) {
      // The switch that selects it and the switch's raw values that do, [low, high] each.
      nlohmann::json values = nlohmann::json::array();
      for (const DbcMuxRange& range : s.mux_ranges) values.push_back({range.low, range.high});
      j["multiplexed_by"] = {{"multiplexer", message.signals[static_cast<std::size_t>(s.mux_parent)].name},
                             {"values", std::move(values)}};
    }
    frame["signals"].push_back(std::move(j));
  }
  out["dbc"] = std::move(frame);
}

void print_dbc(const nlohmann::json& type, std::ostream& out) {
  if (!type.contains("dbc")) return;
  const auto& f = type["dbc"];
  out << "  frame " << f["id"].get<std::string>() << (f["extended"].get<bool>() ? " (extended)" : " (standard)")
      << ", " << f["length"] << " bytes" << (f["fd"].get<bool>() ? ", CAN FD" : "");
  if (f["cycle_time_ms"].get<unsigned>() > 0) out << ", every " << f["cycle_time_ms"] << " ms";
  if (!f["transmitter"].get<std::string>().empty()) out << ", from " << f["transmitter"].get<std::string>();
  out << "\n";
  if (!f.contains("signals")) return;
  for (const auto& s : f["signals"]) {
    char line[512];
    std::snprintf(line, sizeof line, "    %-24s bits %2u|%-2u %-8s %-8s x%g %+g", s["name"].get<std::string>().c_str(),
                  s["start_bit"].get<unsigned>(), s["length"].get<unsigned>(),
                  s["byte_order"].get<std::string>().c_str(),
                  s.contains("float") ? s["float"].get<std::string>().c_str()
                                      : (s["signed"].get<bool>() ? "signed" : "unsigned"),
                  s["factor"].get<double>(), s["offset"].get<double>());
    out << line;
    if (s.contains("range")) out << " [" << s["range"][0].get<double>() << ", " << s["range"][1].get<double>() << "]";
    if (!s["unit"].get<std::string>().empty()) out << " " << s["unit"].get<std::string>();
    if (s.contains("multiplexer")) out << "  multiplexer";
    if (s.contains("multiplexed_by")) {
      out << "  when " << s["multiplexed_by"]["multiplexer"].get<std::string>() << " =";
      const char* separator = " ";
      for (const auto& range : s["multiplexed_by"]["values"]) {
        const auto low = range[0].get<std::int64_t>();
        const auto high = range[1].get<std::int64_t>();
        out << separator << low;
        if (high != low) out << "-" << high;
        separator = ", ";
      }
    }
    out << "\n";
  }
}

}  // namespace polyport::daemon
