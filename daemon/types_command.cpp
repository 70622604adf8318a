#include "types_command.hpp"

#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "polyport/types/types.hpp"
#include "type_printer.hpp"

namespace polyport::daemon {

namespace {

std::string_view origin_name(TypeOrigin origin) {
  switch (origin) {
    case TypeOrigin::builtin: return "builtin";
    case TypeOrigin::idl: return "idl";
    case TypeOrigin::lcm: return "lcm";
    case TypeOrigin::dbc: return "dbc";
  }
  return "?";
}

std::string_view extensibility_name(Extensibility e) {
  switch (e) {
    case Extensibility::final_: return "final";
    case Extensibility::appendable: return "appendable";
    case Extensibility::mutable_: return "mutable";
  }
  return "?";
}

std::string where(const SourceLocation& at) {
  return at.file + ":" + std::to_string(at.line) + ":" + std::to_string(at.column);
}

nlohmann::json describe(const Type& type) {
  nlohmann::json j{{"name", type.name},
                   {"kind", kind_name(type.kind)},
                   {"origin", origin_name(type.origin)},
                   {"size", type.size},
                   {"align", type.align},
                   {"where", where(type.where)}};
  if (type.kind == TypeKind::structure) {
    j["extensibility"] = extensibility_name(type.extensibility);
    for (const Field& field : type.fields) {
      nlohmann::json f{{"name", field.name}, {"type", field.type->name}, {"offset", field.offset},
                       {"size", field.type->size}};
      if (!field.length_fields.empty()) f["length_fields"] = field.length_fields;
      j["fields"].push_back(std::move(f));
    }
  }
  if (type.kind == TypeKind::enumeration) {
    for (const Enumerator& e : type.enumerators) j["enumerators"][e.name] = e.value;
  }
  if (type.kind == TypeKind::alias && type.element) j["aliases"] = type.element->name;
  if (type.origin == TypeOrigin::lcm && type.kind == TypeKind::structure) {
    char hex[32];
    std::snprintf(hex, sizeof hex, "0x%016" PRIx64, type.lcm_fingerprint);
    j["lcm_fingerprint"] = hex;
  }
  if (type.dbc) describe_dbc(*type.dbc, j);
  return j;
}

void print(const nlohmann::json& t) {
  std::cout << t["kind"].get<std::string>() << " " << t["name"].get<std::string>() << "  ("
            << t["origin"].get<std::string>() << ", " << t["where"].get<std::string>() << ")  size "
            << t["size"] << " align " << t["align"];
  if (t.contains("extensibility") && t["origin"] == "idl") std::cout << "  " << t["extensibility"].get<std::string>();
  std::cout << "\n";
  if (t.contains("lcm_fingerprint")) std::cout << "  lcm fingerprint " << t["lcm_fingerprint"].get<std::string>() << "\n";
  if (t.contains("aliases")) std::cout << "  = " << t["aliases"].get<std::string>() << "\n";
  if (t.contains("enumerators")) {
    for (const auto& [name, value] : t["enumerators"].items()) std::cout << "  " << name << " = " << value << "\n";
  }
  print_dbc(t, std::cout);
  if (t.contains("fields")) {
    for (const auto& f : t["fields"]) {
      char line[512];
      std::snprintf(line, sizeof line, "  %6u  %-28s %s", f["offset"].get<unsigned>(),
                    f["type"].get<std::string>().c_str(), f["name"].get<std::string>().c_str());
      std::cout << line;
      if (f.contains("length_fields")) {
        std::cout << "  (length from";
        for (const auto& l : f["length_fields"]) std::cout << " " << l.get<std::string>();
        std::cout << ")";
      }
      std::cout << "\n";
    }
  }
}

}  // namespace

int run_types(const std::vector<std::string>& files, bool json) {
  TypeRegistry registry;
  Diagnostics diagnostics;
  for (const std::string& file : files) registry.add_type_file(file, diagnostics);
  diagnostics.print(std::cerr);
  nlohmann::json all = nlohmann::json::array();
  for (const Type* type : registry.declared()) all.push_back(describe(*type));
  if (json) {
    std::cout << all.dump(2) << "\n";
  } else {
    for (const auto& t : all) print(t);
  }
  return diagnostics.has_errors() ? 3 : 0;
}

}  // namespace polyport::daemon
