#include "polyport/codecs/codec.hpp"

namespace polyport {

std::string_view to_string(WireFormat format) noexcept {
  switch (format) {
    case WireFormat::flat: return "flat";
    case WireFormat::xcdr1: return "xcdr1";
    case WireFormat::xcdr2: return "xcdr2";
    case WireFormat::lcm: return "lcm";
    case WireFormat::dbc: return "dbc";
  }
  return "?";
}

std::string_view to_string(CodecError error) noexcept {
  switch (error) {
    case CodecError::ok: return "ok";
    case CodecError::truncated: return "truncated";
    case CodecError::output_too_small: return "output_too_small";
    case CodecError::bad_header: return "bad_header";
    case CodecError::fingerprint_mismatch: return "fingerprint_mismatch";
    case CodecError::bound_exceeded: return "bound_exceeded";
    case CodecError::bad_value: return "bad_value";
    case CodecError::wrong_size: return "wrong_size";
    case CodecError::trailing_bytes: return "trailing_bytes";
  }
  return "?";
}

Result<std::unique_ptr<Codec>> make_codec(WireFormat format, const Type& type) {
  switch (format) {
    case WireFormat::xcdr1:
    case WireFormat::xcdr2: return make_cdr_codec(type, format);
    case WireFormat::lcm: return make_lcm_codec(type);
    case WireFormat::dbc: return make_dbc_codec(type);
    case WireFormat::flat: break;
  }
  return make_error("the flat format needs no codec");
}

}  // namespace polyport
