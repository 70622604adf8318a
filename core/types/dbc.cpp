// The look-ups dbc.hpp declares: a message's signal by name, a database's message by CAN id
// or name, and the DBC databases a registry holds.
#include <algorithm>
#include <cstdint>
#include <string_view>
#include <utility>
#include <vector>

#include "polyport/types/dbc.hpp"
#include "polyport/types/types.hpp"

namespace polyport {

const DbcSignal* DbcMessage::find_signal(std::string_view signal_name) const noexcept {
  for (const DbcSignal& signal : signals) {
    if (signal.name == signal_name) return &signal;
  }
  return nullptr;
}

const DbcMessage* DbcDatabase::find_message(std::uint32_t can_id) const noexcept {
  // RTR and error flags are not part of the identity; the extended flag is.
  const std::uint32_t key = (can_id & kCanExtendedFlag) != 0
                                ? can_id & (kCanExtendedFlag | kCanExtendedIdMask)
                                : can_id & kCanStandardIdMask;
  auto it = std::lower_bound(by_can_id.begin(), by_can_id.end(), key,
                             [](const std::pair<std::uint32_t, std::uint32_t>& item, std::uint32_t value) {
                               return item.first < value;
                             });
  if (it == by_can_id.end() || it->first != key) return nullptr;
  return &messages[it->second];
}

const DbcMessage* DbcDatabase::find_message(std::string_view message_name) const noexcept {
  for (const DbcMessage& message : messages) {
    if (message.name == message_name) return &message;
  }
  return nullptr;
}

std::vector<const DbcDatabase*> dbc_databases(const TypeRegistry& registry) {
  std::vector<const DbcDatabase*> out;
  for (const Type* type : registry.declared()) {
    if (type->origin != TypeOrigin::dbc || type->dbc == nullptr) continue;
    const DbcDatabase* database = type->dbc->database;
    if (database != nullptr && std::find(out.begin(), out.end(), database) == out.end()) {
      out.push_back(database);
    }
  }
  return out;
}

const DbcDatabase* find_dbc_database(const TypeRegistry& registry, std::string_view name) {
  for (const DbcDatabase* database : dbc_databases(registry)) {
    if (database->name == name) return database;
  }
  return nullptr;
}

}  // namespace polyport
