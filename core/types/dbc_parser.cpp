// DBC files as a type source (dbc.hpp): parse_dbc, behind TypeRegistry::add_dbc_file /
// add_dbc_text.
//
// Set-up code, run once per file. It reports every problem it finds as file:line:col
// (columns count bytes) and keeps going: after an error it skips to the next `;` or the
// next line that starts with a DBC keyword. Statements that point at a message or signal
// (CM_, BA_, VAL_, SIG_VALTYPE_, ...) are resolved after the whole file is read, so their
// order in the file does not matter, and the problems are reported sorted by position.
// Only messages without problems are registered as types.
//
// DBC files as vehicle and robot tools write them must load, so only syntax errors fail a
// file. What polyport does not model (EV_, SIG_GROUP_, relation attributes, ...) and
// statements naming what the file does not define are skipped with one warning per kind
// (DbcParser::once). A problem confined to one message (overlapping signals, a signal beyond
// the frame, multiplexers that select each other, a duplicate id) gives that message one warning and
// declares its name unusable (TypeRegistry::declare_unusable): a profile that names it fails
// with the reason, the others are unaffected.
//
// This file drives the passes (dbc_lexer.cpp, dbc_statements.cpp and dbc_messages.cpp,
// dbc_resolve.cpp) and registers a struct type per message of the database they built.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "dbc_lexer.hpp"
#include "dbc_parser_impl.hpp"
#include "polyport/types/dbc.hpp"
#include "polyport/types/dbc_parser.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

namespace dbc_detail {
namespace {

std::string sanitise_identifier(std::string_view text) {
  std::string out;
  for (const char c : text) out += is_identifier_char(c) ? c : '_';
  if (out.empty()) return "dbc";
  if (is_digit(out[0])) out.insert(out.begin(), '_');
  return out;
}

}  // namespace
}  // namespace dbc_detail

bool parse_dbc(std::string_view text, const std::string& file_name, TypeRegistry& registry,
               Diagnostics& diagnostics) {
  using dbc_detail::DbcParser;
  using dbc_detail::ParsedMessage;
  using dbc_detail::Problem;
  DbcParser parser(file_name);
  parser.tokens_ = dbc_detail::lex_dbc(text, parser.problems_);
  while (!parser.at_end()) parser.statement();
  parser.resolve();
  for (ParsedMessage& parsed : parser.messages_) {
    if (!parsed.pseudo) parser.check_message(parsed);
  }

  std::shared_ptr<DbcDatabase> database = parser.database_;
  database->file = file_name;
  database->name = dbc_detail::sanitise_identifier(std::filesystem::path(file_name).stem().string());
  // Messages with a problem of their own: one warning each, and declared unusable so that a
  // profile naming one says why.
  for (const ParsedMessage& parsed : parser.messages_) {
    if (parsed.pseudo || parsed.problem.empty()) continue;
    dbc_detail::Token at;
    at.line = parsed.problem_line;
    at.column = parsed.problem_column;
    std::string more;
    if (parsed.more_problems > 0) {
      more = " (and " + std::to_string(parsed.more_problems) +
             (parsed.more_problems == 1 ? " more problem)" : " more problems)");
    }
    parser.warning(at, "message '" + parsed.message.name + "' cannot be used: " + parsed.problem + more);
    registry.declare_unusable({database->name + "::" + parsed.message.name,
                               SourceLocation{file_name, parsed.problem_line, parsed.problem_column},
                               parsed.problem});
  }
  for (dbc_detail::Occurrences& item : parser.occurrences_) {
    parser.problems_.push_back({item.line, item.column, Severity::warning,
                                item.message + " (" + std::to_string(item.count) + " in this file)"});
  }
  for (ParsedMessage& parsed : parser.messages_) {
    if (parsed.pseudo || parsed.broken) continue;
    parsed.message.database = database.get();
    database->messages.push_back(std::move(parsed.message));
  }
  // Registered only once the vector is complete: each type points into it.
  const Type* float64 = registry.primitive(TypeKind::float64);
  for (std::uint32_t i = 0; i < database->messages.size(); ++i) {
    DbcMessage& message = database->messages[i];
    database->by_can_id.emplace_back(message.can_id(), i);
    const std::string name = database->name + "::" + message.name;
    if (registry.find_exact(name) != nullptr) {
      parser.problems_.push_back({message.where.line, message.where.column, Severity::error,
                                  "redefinition of '" + name + "'"});
      continue;
    }
    Type type;
    type.kind = TypeKind::structure;
    type.name = name;
    type.where = message.where;
    type.origin = TypeOrigin::dbc;
    type.dbc = &message;
    for (const DbcSignal& signal : message.signals) {
      Field field;
      field.name = signal.name;
      field.type = float64;
      field.where = signal.where;
      type.fields.push_back(std::move(field));
    }
    TypeRegistry::layout_struct(type);  // at most kDbcMaxSignals doubles: within the size limit
    Type& stored = registry.make_type();
    stored = std::move(type);
    registry.declare(stored);
    message.type = &stored;
  }
  std::sort(database->by_can_id.begin(), database->by_can_id.end());
  registry.retain(database);

  std::stable_sort(parser.problems_.begin(), parser.problems_.end(), [](const Problem& a, const Problem& b) {
    return a.line != b.line ? a.line < b.line : a.column < b.column;
  });
  bool ok = true;
  for (Problem& problem : parser.problems_) {
    SourceLocation location{file_name, problem.line, problem.column};
    if (problem.severity == Severity::error) {
      ok = false;
      diagnostics.error(std::move(location), {}, std::move(problem.message));
    } else {
      diagnostics.warning(std::move(location), {}, std::move(problem.message));
    }
  }
  return ok;
}

}  // namespace polyport
