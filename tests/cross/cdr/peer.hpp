// A reference CDR implementation as the cross test sees it: serializes the values of
// cdr_cross.idl with its own generated code and reads serialized data back into them.
// One implementation per vendor (cyclone_peer.cpp, fastdds_peer.cpp), each built only when
// that vendor's SDK and code generator are installed.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "values.hpp"

namespace cdr_values {

using Bytes = std::vector<std::uint8_t>;

enum class Xcdr { v1, v2 };

enum class ByteOrder { native, big };

class Peer {
 public:
  virtual ~Peer() = default;
  virtual std::string name() const = 0;

  // Whether the peer writes this version for this type at all ("Composite", ...), and
  // whether it can write big-endian data.
  virtual bool writes(const std::string& type, Xcdr version) const = 0;
  virtual bool writes_big_endian(const std::string& type, Xcdr version) const = 0;
  // Whether its generated code reads the type back at all.
  virtual bool reads(const std::string& type) const = 0;

  // The serialized sample with its 4-byte encapsulation header, exactly as the vendor
  // produces it; nothing when the vendor fails.
  virtual std::optional<Bytes> encode(const Primitives& value, Xcdr version, ByteOrder order) = 0;
  virtual std::optional<Bytes> encode(const Composite& value, Xcdr version, ByteOrder order) = 0;
  virtual std::optional<Bytes> encode(const Labels& value, Xcdr version, ByteOrder order) = 0;
  virtual std::optional<Bytes> encode(const Stamped& value, Xcdr version, ByteOrder order) = 0;
  virtual std::optional<Bytes> encode(const Envelope& value, Xcdr version, ByteOrder order) = 0;

  // Reads serialized data (header included) with the vendor's deserializer; false when it
  // refuses the data.
  virtual bool decode(const Bytes& wire, Primitives& value) = 0;
  virtual bool decode(const Bytes& wire, Composite& value) = 0;
  virtual bool decode(const Bytes& wire, Labels& value) = 0;
  virtual bool decode(const Bytes& wire, Stamped& value) = 0;
  virtual bool decode(const Bytes& wire, Envelope& value) = 0;
};

#ifdef POLYPORT_CDR_CYCLONE
std::unique_ptr<Peer> make_cyclone_peer();
#endif
#ifdef POLYPORT_CDR_FASTDDS
std::unique_ptr<Peer> make_fastdds_peer();
#endif

}  // namespace cdr_values
