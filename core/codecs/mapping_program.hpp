// The program a mapping compiles to (mapping_compiler.hpp) and runs (mapping_run.cpp): a flat
// vector of Steps and the tables they point into, immutable once compiled; and the number
// kinds, loads, stores and conversions that compiling and running share.
//
// Steps are frame-relative: offsets count from the start of the struct being written. The
// top-level steps run in the frame of the whole sample; the steps of a sequence or array
// body follow the step that owns them and run once per element, in that element's frame.
// Unbounded strings and sequences of the target are appended to the target's tail, after
// its fixed part; FlatSpan offsets are from the start of the sample on both sides.
//
// Private to the codecs layer. Hidden, so that nothing here is exported from libpolyport_core
// (as nothing was while all of it lived in one file's anonymous namespace) and calls between
// the mapping files stay direct. What the forwarding path uses from here (load, store,
// from_double, convert_value, align_up) is inline, as it was in the one file.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "polyport/codecs/mapping.hpp"

#pragma GCC visibility push(hidden)

namespace polyport::mapping {

// ---------------------------------------------------------------------------------------
// Numbers

enum class Num : std::uint8_t { i8, u8, i16, u16, i32, u32, i64, u64, f32, f64 };

inline std::optional<Num> number_kind(TypeKind kind) noexcept {
  switch (kind) {
    case TypeKind::int8: return Num::i8;
    case TypeKind::uint8:
    case TypeKind::octet: return Num::u8;
    case TypeKind::int16: return Num::i16;
    case TypeKind::uint16: return Num::u16;
    case TypeKind::int32: return Num::i32;
    case TypeKind::uint32: return Num::u32;
    case TypeKind::int64: return Num::i64;
    case TypeKind::uint64: return Num::u64;
    case TypeKind::float32: return Num::f32;
    case TypeKind::float64: return Num::f64;
    default: return std::nullopt;
  }
}

// Calls f with std::type_identity<T> for the C++ type of `kind`; compiles to one switch.
template <class F>
decltype(auto) with_number(Num kind, F&& f) {
  switch (kind) {
    case Num::i8: return f(std::type_identity<std::int8_t>{});
    case Num::u8: return f(std::type_identity<std::uint8_t>{});
    case Num::i16: return f(std::type_identity<std::int16_t>{});
    case Num::u16: return f(std::type_identity<std::uint16_t>{});
    case Num::i32: return f(std::type_identity<std::int32_t>{});
    case Num::u32: return f(std::type_identity<std::uint32_t>{});
    case Num::i64: return f(std::type_identity<std::int64_t>{});
    case Num::u64: return f(std::type_identity<std::uint64_t>{});
    case Num::f32: return f(std::type_identity<float>{});
    case Num::f64: break;
  }
  return f(std::type_identity<double>{});
}

inline std::uint32_t number_size(Num kind) noexcept {
  return with_number(kind, [](auto t) {
    return static_cast<std::uint32_t>(sizeof(typename decltype(t)::type));
  });
}

inline bool is_float(Num kind) noexcept { return kind == Num::f32 || kind == Num::f64; }
inline bool is_signed(Num kind) noexcept {
  return kind == Num::i8 || kind == Num::i16 || kind == Num::i32 || kind == Num::i64;
}

// Whether every value of `from` is a value of `to`, the integers into double counted as
// the task's "widening" even though int64 -> double may round (no range is lost).
inline bool widens(Num from, Num to) noexcept {
  if (from == to) return true;
  if (to == Num::f64) return true;
  if (to == Num::f32) return !is_float(from) && number_size(from) <= 2;
  if (is_float(from)) return false;
  if (is_signed(from) == is_signed(to)) return number_size(to) >= number_size(from);
  return !is_signed(from) && number_size(to) > number_size(from);
}

// Sample fields need not be aligned in memory (the caller's buffer may not be): memcpy.
template <class T>
T load(const std::byte* at) noexcept {
  T value;
  std::memcpy(&value, at, sizeof value);
  return value;
}

template <class T>
void store(std::byte* at, T value) noexcept {
  std::memcpy(at, &value, sizeof value);
}

// double -> T, for every conversion that goes through double. Integers round to nearest
// (half away from zero) and saturate at T's range; NaN becomes 0. A double beyond float's
// range saturates at the largest float, since the C++ conversion would be undefined.
template <class T>
T from_double(double value) noexcept {
  if constexpr (std::is_integral_v<T>) {
    if (std::isnan(value)) return 0;
    const double rounded = std::round(value);
    // 2^digits is exactly representable and is one past T's maximum.
    constexpr double kLimit = static_cast<double>(std::uint64_t{1} << (std::numeric_limits<T>::digits - 1)) * 2.0;
    constexpr double kLowest = std::is_signed_v<T> ? -kLimit : 0.0;
    if (rounded >= kLimit) return std::numeric_limits<T>::max();
    if (rounded < kLowest) return std::numeric_limits<T>::min();
    return static_cast<T>(rounded);
  } else if constexpr (std::is_same_v<T, float>) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (value > kMax && std::isfinite(value)) return std::numeric_limits<float>::max();
    if (value < -kMax && std::isfinite(value)) return std::numeric_limits<float>::lowest();
    return static_cast<float>(value);
  } else {
    return value;
  }
}

template <class T, class S>
T convert_value(S value) noexcept {
  if constexpr (std::is_integral_v<T> && std::is_integral_v<S>) {
    if (std::in_range<T>(value)) return static_cast<T>(value);
    return value < 0 ? std::numeric_limits<T>::min() : std::numeric_limits<T>::max();
  } else if constexpr (std::is_floating_point_v<T> && std::is_integral_v<S>) {
    return static_cast<T>(value);  // in range for every integer type; rounds to nearest
  } else {
    return from_double<T>(static_cast<double>(value));
  }
}

using ConvertFn = void (*)(const std::byte* src, std::byte* dst, std::uint32_t count,
                           std::uint32_t src_stride, std::uint32_t dst_stride) noexcept;
using ScaleFn = void (*)(const std::byte* src, std::byte* dst, std::uint32_t count,
                         std::uint32_t src_stride, std::uint32_t dst_stride, double scale,
                         double offset) noexcept;

// ---------------------------------------------------------------------------------------
// Vector fields, for the matrix kernels (mapping_transforms.cpp)

struct VectorElement {
  Num kind;
  std::uint32_t offset;  // in the frame of the vector field's owner
};

using TransformFn = void (*)(const std::byte* src, std::byte* dst, const double* matrix,
                             const VectorElement* elements) noexcept;

// ---------------------------------------------------------------------------------------
// The program

enum class Op : std::uint8_t {
  zero,           // size bytes at dst := 0
  copy,           // size bytes src -> dst
  convert,        // count numbers, strides, through `convert`
  scale,          // count numbers: dst = src * scale + offset, through `scaled`
  enum_map,       // int32 src -> int32 dst through the pairs at enum_pairs_[pool]
  constant,       // size bytes from constants_[pool] -> dst
  tail_constant,  // an unbounded target string: pool_count chars from constants_[pool]
  string,         // a string, bounded or unbounded on either side
  sequence,       // a sequence, bounded or unbounded on either side; body per element
  repeat,         // a fixed array whose elements need a body: count times
  transform,      // y = M x (+ t) on vector fields, through `transform`
  length,         // an LCM length member := the element count of the target sequence at
                  // `counted` (already written), through `convert` from uint32; fails when the
                  // count is above dst_bound (the member's range) or, with `compare`, when it
                  // differs from what an earlier length step stored (two sequences, one length)
};

struct Step {
  Op op = Op::copy;
  bool src_unbounded = false;
  bool dst_unbounded = false;
  bool truncate = false;
  bool compare = false;          // length: check the stored value instead of storing
  std::uint32_t src = 0;         // offsets in the current frame
  std::uint32_t dst = 0;
  std::uint32_t size = 0;        // bytes (copy, zero, constant); the target region (string,
                                 // sequence); one target number (convert, scale, length)
  std::uint32_t count = 1;       // numbers (convert, scale), elements (repeat), rows (transform)
  std::uint32_t src_stride = 0;  // element sizes (convert, scale, sequence, repeat)
  std::uint32_t dst_stride = 0;
  std::uint32_t src_bound = 0;   // string and sequence bounds; 0 with *_unbounded
  std::uint32_t dst_bound = 0;   // length: the largest count the member holds
  std::uint32_t src_first = 0;   // bounded sequences: first element, from the sequence
  std::uint32_t dst_first = 0;
  std::uint32_t dst_align = 1;   // unbounded target sequence: alignment of its tail block
  std::uint32_t body = 0;        // steps after this one that run per element
  std::uint32_t pool = 0;        // first entry in the program's table for this step
  std::uint32_t pool_count = 0;  // entries (enum pairs, chars) or columns (transform)
  std::uint32_t elements = 0;    // transform: first VectorElement
  std::uint32_t counted = 0;     // length: the target sequence, an offset in the *target* frame
  double scale = 1.0;
  double offset = 0.0;
  ConvertFn convert = nullptr;
  ScaleFn scaled = nullptr;
  TransformFn transform = nullptr;
};

inline std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) noexcept {
  if (alignment <= 1) return value;
  return (value + alignment - 1) / alignment * alignment;
}

class CompiledMapping final : public MappingProgram {
 public:
  // The forwarding path (mapping_run.cpp).
  bool run(const std::byte* source, std::uint32_t source_size, std::byte* target,
           std::uint32_t target_capacity, std::uint32_t& target_size) const noexcept override;
  // The lines of `polyportd check` (mapping.cpp).
  std::vector<std::string> describe() const override;
  const void* program_data() const noexcept override { return steps_.data(); }

  std::vector<Step> steps_;
  std::vector<std::string> notes_;  // what each step maps, for describe()
  std::vector<std::int32_t> enum_pairs_;  // (source value, target value), sorted per table
  std::vector<std::byte> constants_;
  std::vector<double> numbers_;           // matrices, then their translations
  std::vector<VectorElement> elements_;
  std::uint32_t source_fixed_ = 0;
  std::uint32_t target_fixed_ = 0;

 private:
  struct State;

  // The forwarding path (mapping_run.cpp). Inline, as they were in the one file: each is
  // defined in mapping_run.cpp, the one file that calls them.
  static inline bool reserve_tail(State& state, std::uint64_t bytes, std::uint32_t alignment,
                                  std::uint32_t& at) noexcept;
  static inline bool span_fits(const State& state, std::uint64_t offset, std::uint64_t bytes) noexcept;
  inline bool run_string(const Step& step, const std::byte* src, std::byte* dst, State& state) const noexcept;
  inline bool run_sequence(const Step* step, const std::byte* src, std::byte* dst, std::uint32_t dst_frame,
                           State& state) const noexcept;
  static inline bool run_length(const Step& step, std::byte* dst, std::uint32_t dst_frame, State& state) noexcept;
  inline bool run_steps(const Step* first, const Step* last, std::uint32_t src_frame, std::uint32_t dst_frame,
                        State& state) const noexcept;

  // describe() (mapping.cpp).
  void describe_steps(std::size_t first, std::size_t last, int depth, std::vector<std::string>& lines) const;
};

}  // namespace polyport::mapping

#pragma GCC visibility pop
