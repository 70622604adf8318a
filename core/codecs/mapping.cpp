// Mappings between two flat sample layouts (see mapping.hpp and types.hpp).
//
// compile() runs once at load time: it walks the target type, pairs every target field with
// a source field (by name, or by a rule), checks that each pair can convert, and emits a
// flat vector of Steps (copy bytes, convert a number, scale, look an enum up, write a
// constant, copy a string or sequence, apply a matrix). Adjacent copies are merged, and the
// target bytes no step writes (padding, fields left unset) get explicit zero steps, so
// run() never has to clear the whole sample first.
//
// run() is the forwarding path. It runs on the thread of the writer that delivers a sample
// (Connection::deliver), reads the caller's source buffer and writes the caller's target
// buffer; it owns no buffer and touches no shared state other than the program, which is
// immutable after compile(), so one program may run on several threads at once. It does not
// allocate, lock or throw: every table it needs (enum pairs, constants, matrices, vector
// element lists) lives in vectors filled at compile time, and matrix products use Eigen
// fixed-size types chosen by a dispatch on (rows, cols).
//
// Steps are frame-relative: offsets count from the start of the struct being written. The
// top-level steps run in the frame of the whole sample; the steps of a sequence or array
// body follow the step that owns them and run once per element, in that element's frame.
// Unbounded strings and sequences of the target are appended to the target's tail, after
// its fixed part; FlatSpan offsets are from the start of the sample on both sides.
#include "polyport/codecs/mapping.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <string_view>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

namespace polyport {

namespace {

// ---------------------------------------------------------------------------------------
// Numbers

enum class Num : std::uint8_t { i8, u8, i16, u16, i32, u32, i64, u64, f32, f64 };

std::optional<Num> number_kind(TypeKind kind) noexcept {
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

std::uint32_t number_size(Num kind) noexcept {
  return with_number(kind, [](auto t) {
    return static_cast<std::uint32_t>(sizeof(typename decltype(t)::type));
  });
}

bool is_float(Num kind) noexcept { return kind == Num::f32 || kind == Num::f64; }
bool is_signed(Num kind) noexcept {
  return kind == Num::i8 || kind == Num::i16 || kind == Num::i32 || kind == Num::i64;
}

// Whether every value of `from` is a value of `to`, the integers into double counted as
// the task's "widening" even though int64 -> double may round (no range is lost).
bool widens(Num from, Num to) noexcept {
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

double load_number(Num kind, const std::byte* at) noexcept {
  return with_number(kind, [at](auto t) {
    return static_cast<double>(load<typename decltype(t)::type>(at));
  });
}

void store_number(Num kind, std::byte* at, double value) noexcept {
  with_number(kind, [at, value](auto t) {
    using T = typename decltype(t)::type;
    store<T>(at, from_double<T>(value));
  });
}

using ConvertFn = void (*)(const std::byte* src, std::byte* dst, std::uint32_t count,
                           std::uint32_t src_stride, std::uint32_t dst_stride) noexcept;
using ScaleFn = void (*)(const std::byte* src, std::byte* dst, std::uint32_t count,
                         std::uint32_t src_stride, std::uint32_t dst_stride, double scale,
                         double offset) noexcept;

template <class S, class T>
void convert_numbers(const std::byte* src, std::byte* dst, std::uint32_t count,
                     std::uint32_t src_stride, std::uint32_t dst_stride) noexcept {
  for (std::uint32_t i = 0; i < count; ++i) {
    store<T>(dst + std::size_t{i} * dst_stride, convert_value<T>(load<S>(src + std::size_t{i} * src_stride)));
  }
}

template <class S, class T>
void scale_numbers(const std::byte* src, std::byte* dst, std::uint32_t count,
                   std::uint32_t src_stride, std::uint32_t dst_stride, double scale,
                   double offset) noexcept {
  for (std::uint32_t i = 0; i < count; ++i) {
    const double value = static_cast<double>(load<S>(src + std::size_t{i} * src_stride));
    store<T>(dst + std::size_t{i} * dst_stride, from_double<T>(value * scale + offset));
  }
}

ConvertFn pick_converter(Num from, Num to) {
  return with_number(from, [to](auto s) {
    return with_number(to, [](auto t) -> ConvertFn {
      return &convert_numbers<typename decltype(s)::type, typename decltype(t)::type>;
    });
  });
}

ScaleFn pick_scaler(Num from, Num to) {
  return with_number(from, [to](auto s) {
    return with_number(to, [](auto t) -> ScaleFn {
      return &scale_numbers<typename decltype(s)::type, typename decltype(t)::type>;
    });
  });
}

// ---------------------------------------------------------------------------------------
// Matrix kernels: one instantiation per (rows, cols, affine), so the product is Eigen's
// fixed-size code (unrolled, on the stack) whatever the vector fields' element types.

constexpr int kMaxVector = 6;

struct VectorElement {
  Num kind;
  std::uint32_t offset;  // in the frame of the vector field's owner
};

using TransformFn = void (*)(const std::byte* src, std::byte* dst, const double* matrix,
                             const VectorElement* elements) noexcept;

// `elements` holds the C source elements, then the R target elements; `matrix` the R x C
// entries row-major, then (affine) the R entries of the translation. Vectors of doubles (the
// usual case) skip the per-element dispatch on the element type.
template <int R, int C, bool Affine, bool AllDouble>
void transform_kernel(const std::byte* src, std::byte* dst, const double* matrix,
                      const VectorElement* elements) noexcept {
  Eigen::Matrix<double, C, 1> x;
  for (int c = 0; c < C; ++c) {
    if constexpr (AllDouble) {
      x(c) = load<double>(src + elements[c].offset);
    } else {
      x(c) = load_number(elements[c].kind, src + elements[c].offset);
    }
  }
  // Eigen wants column vectors column-major and row vectors row-major.
  constexpr int kOrder = C == 1 ? Eigen::ColMajor : Eigen::RowMajor;
  const Eigen::Map<const Eigen::Matrix<double, R, C, kOrder>> m(matrix);
  // Row by row: g++ inlines these fixed-size dot products, whereas it calls the assignment
  // loop of `m * x` out of line, which costs more than a 3x3 product itself.
  Eigen::Matrix<double, R, 1> y;
  for (int r = 0; r < R; ++r) y(r) = m.row(r).dot(x);
  if constexpr (Affine) y += Eigen::Map<const Eigen::Matrix<double, R, 1>>(matrix + R * C);
  for (int r = 0; r < R; ++r) {
    if constexpr (AllDouble) {
      store<double>(dst + elements[C + r].offset, y(r));
    } else {
      store_number(elements[C + r].kind, dst + elements[C + r].offset, y(r));
    }
  }
}

template <int R, int C>
TransformFn kernel_for(bool affine, bool all_double) {
  if (all_double) return affine ? &transform_kernel<R, C, true, true> : &transform_kernel<R, C, false, true>;
  return affine ? &transform_kernel<R, C, true, false> : &transform_kernel<R, C, false, false>;
}

template <int R>
TransformFn kernel_for_cols(int cols, bool affine, bool all_double) {
  switch (cols) {
    case 1: return kernel_for<R, 1>(affine, all_double);
    case 2: return kernel_for<R, 2>(affine, all_double);
    case 3: return kernel_for<R, 3>(affine, all_double);
    case 4: return kernel_for<R, 4>(affine, all_double);
    case 5: return kernel_for<R, 5>(affine, all_double);
    case 6: return kernel_for<R, 6>(affine, all_double);
    default: return nullptr;
  }
}

// The (rows, cols) dispatch: 1..6 each, so every product is a fixed-size Eigen one.
TransformFn pick_kernel(int rows, int cols, bool affine, bool all_double) {
  switch (rows) {
    case 1: return kernel_for_cols<1>(cols, affine, all_double);
    case 2: return kernel_for_cols<2>(cols, affine, all_double);
    case 3: return kernel_for_cols<3>(cols, affine, all_double);
    case 4: return kernel_for_cols<4>(cols, affine, all_double);
    case 5: return kernel_for_cols<5>(cols, affine, all_double);
    case 6: return kernel_for_cols<6>(cols, affine, all_double);
    default: return nullptr;
  }
}

// ---------------------------------------------------------------------------------------
// Units: value_in_base = value * factor + offset (the offset only for temperatures).

struct Unit {
  std::string_view name;
  std::string_view dimension;
  double factor;
  double offset;
};

constexpr double kPi = 3.14159265358979323846;

constexpr Unit kUnits[] = {
    {"rad", "angle", 1.0, 0.0},
    {"deg", "angle", kPi / 180.0, 0.0},
    {"m", "length", 1.0, 0.0},
    {"cm", "length", 1e-2, 0.0},
    {"mm", "length", 1e-3, 0.0},
    {"km", "length", 1e3, 0.0},
    {"s", "time", 1.0, 0.0},
    {"ms", "time", 1e-3, 0.0},
    {"us", "time", 1e-6, 0.0},
    {"ns", "time", 1e-9, 0.0},
    {"m/s", "speed", 1.0, 0.0},
    {"km/h", "speed", 1000.0 / 3600.0, 0.0},
    {"mph", "speed", 0.44704, 0.0},  // 1609.344 m per hour, exactly
    {"rad/s", "angular velocity", 1.0, 0.0},
    {"deg/s", "angular velocity", kPi / 180.0, 0.0},
    {"rpm", "angular velocity", 2.0 * kPi / 60.0, 0.0},
    {"kg", "mass", 1.0, 0.0},
    {"g", "mass", 1e-3, 0.0},
    {"K", "temperature", 1.0, 0.0},
    {"degC", "temperature", 1.0, 273.15},
    {"degF", "temperature", 5.0 / 9.0, 273.15 - 32.0 * 5.0 / 9.0},
    {"Pa", "pressure", 1.0, 0.0},
    {"kPa", "pressure", 1e3, 0.0},
    {"bar", "pressure", 1e5, 0.0},
    {"psi", "pressure", 6894.757293168361, 0.0},  // lbf/in^2
};

const Unit* find_unit(std::string_view name) noexcept {
  for (const Unit& unit : kUnits) {
    if (unit.name == name) return &unit;
  }
  return nullptr;
}

std::string known_units() {
  std::string out;
  for (const Unit& unit : kUnits) {
    if (!out.empty()) out += ", ";
    out += unit.name;
  }
  return out;
}

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
};

struct Step {
  Op op = Op::copy;
  bool src_unbounded = false;
  bool dst_unbounded = false;
  bool truncate = false;
  std::uint32_t src = 0;         // offsets in the current frame
  std::uint32_t dst = 0;
  std::uint32_t size = 0;        // bytes (copy, zero, constant); the target region (string,
                                 // sequence); one target number (convert, scale)
  std::uint32_t count = 1;       // numbers (convert, scale), elements (repeat), rows (transform)
  std::uint32_t src_stride = 0;  // element sizes (convert, scale, sequence, repeat)
  std::uint32_t dst_stride = 0;
  std::uint32_t src_bound = 0;   // string and sequence bounds; 0 with *_unbounded
  std::uint32_t dst_bound = 0;
  std::uint32_t src_first = 0;   // bounded sequences: first element, from the sequence
  std::uint32_t dst_first = 0;
  std::uint32_t dst_align = 1;   // unbounded target sequence: alignment of its tail block
  std::uint32_t body = 0;        // steps after this one that run per element
  std::uint32_t pool = 0;        // first entry in the program's table for this step
  std::uint32_t pool_count = 0;  // entries (enum pairs, chars) or columns (transform)
  std::uint32_t elements = 0;    // transform: first VectorElement
  double scale = 1.0;
  double offset = 0.0;
  ConvertFn convert = nullptr;
  ScaleFn scaled = nullptr;
  TransformFn transform = nullptr;
};

std::uint64_t align_up(std::uint64_t value, std::uint64_t alignment) noexcept {
  if (alignment <= 1) return value;
  return (value + alignment - 1) / alignment * alignment;
}

class CompiledMapping final : public MappingProgram {
 public:
  bool run(const std::byte* source, std::uint32_t source_size, std::byte* target,
           std::uint32_t target_capacity, std::uint32_t& target_size) const noexcept override {
    if (source == nullptr || target == nullptr) return false;
    if (source_size < source_fixed_ || target_capacity < target_fixed_) return false;
    State state{source, source_size, target, target_capacity, target_fixed_};
    if (!run_steps(steps_.data(), steps_.data() + steps_.size(), 0, 0, state)) return false;
    target_size = state.tail;
    return true;
  }

  std::vector<std::string> describe() const override {
    std::vector<std::string> lines;
    describe_steps(0, steps_.size(), 0, lines);
    return lines;
  }

  std::vector<Step> steps_;
  std::vector<std::string> notes_;  // what each step maps, for describe()
  std::vector<std::int32_t> enum_pairs_;  // (source value, target value), sorted per table
  std::vector<std::byte> constants_;
  std::vector<double> numbers_;           // matrices, then their translations
  std::vector<VectorElement> elements_;
  std::uint32_t source_fixed_ = 0;
  std::uint32_t target_fixed_ = 0;

 private:
  struct State {
    const std::byte* source;
    std::uint32_t source_size;
    std::byte* target;
    std::uint32_t capacity;
    std::uint32_t tail;  // the next free byte of the target's tail
  };

  // Reserves `bytes` of the target's tail aligned to `alignment`, zeroing the alignment gap
  // so equal inputs give equal bytes; returns its offset, or nothing when it does not fit.
  static bool reserve_tail(State& state, std::uint64_t bytes, std::uint32_t alignment,
                           std::uint32_t& at) noexcept {
    const std::uint64_t start = align_up(state.tail, alignment);
    if (start > state.capacity || bytes > state.capacity - start) return false;
    std::memset(state.target + state.tail, 0, start - state.tail);
    at = static_cast<std::uint32_t>(start);
    state.tail = static_cast<std::uint32_t>(start + bytes);
    return true;
  }

  // A source span must lie inside the sample: `bytes` from `offset`.
  static bool span_fits(const State& state, std::uint64_t offset, std::uint64_t bytes) noexcept {
    return offset <= state.source_size && bytes <= state.source_size - offset;
  }

  bool run_string(const Step& step, const std::byte* src, std::byte* dst, State& state) const noexcept {
    const char* chars = nullptr;
    std::uint64_t length = 0;
    if (step.src_unbounded) {
      const auto span = load<FlatSpan>(src);
      if (!span_fits(state, span.offset, span.count)) return false;
      chars = reinterpret_cast<const char*>(state.source + span.offset);
      length = span.count;
    } else {
      chars = reinterpret_cast<const char*>(src);
      length = strnlen(chars, step.src_bound);
    }
    if (step.dst_unbounded) {
      std::uint32_t at = 0;
      if (!reserve_tail(state, length + 1, 1, at)) return false;
      std::memcpy(state.target + at, chars, length);
      state.target[at + length] = std::byte{0};
      store(dst, FlatSpan{at, static_cast<std::uint32_t>(length)});
      return true;
    }
    if (length > step.dst_bound) {
      if (!step.truncate) return false;
      length = step.dst_bound;
      // Do not cut a UTF-8 character in two: back off over its continuation bytes.
      while (length > 0 && (static_cast<unsigned char>(chars[length]) & 0xC0) == 0x80) --length;
    }
    std::memcpy(dst, chars, length);
    std::memset(dst + length, 0, step.dst_bound + 1 - length);
    return true;
  }

  bool run_sequence(const Step* step, const std::byte* src, std::byte* dst, std::uint32_t dst_frame,
                    State& state) const noexcept {
    std::uint64_t count = 0;
    std::uint64_t src_first = 0;  // from the start of the source sample
    if (step->src_unbounded) {
      const auto span = load<FlatSpan>(src);
      count = span.count;
      src_first = span.offset;
      if (!span_fits(state, src_first, count * step->src_stride)) return false;
    } else {
      count = load<std::uint32_t>(src);
      if (count > step->src_bound) return false;
      src_first = static_cast<std::uint64_t>(src - state.source) + step->src_first;
    }
    std::uint64_t dst_first = 0;
    if (step->dst_unbounded) {
      std::uint32_t at = 0;
      if (!reserve_tail(state, count * step->dst_stride, step->dst_align, at)) return false;
      store(dst, FlatSpan{at, static_cast<std::uint32_t>(count)});
      dst_first = at;
    } else {
      if (count > step->dst_bound) {
        if (!step->truncate) return false;
        count = step->dst_bound;
      }
      store(dst, static_cast<std::uint32_t>(count));
      std::memset(dst + sizeof(std::uint32_t), 0, step->dst_first - sizeof(std::uint32_t));
      const std::uint64_t used = step->dst_first + count * step->dst_stride;
      std::memset(dst + used, 0, step->size - used);
      dst_first = std::uint64_t{dst_frame} + step->dst + step->dst_first;
    }
    if (step->body == 0) {  // elements of one layout: one copy
      std::memcpy(state.target + dst_first, state.source + src_first, count * step->dst_stride);
      return true;
    }
    const Step* body = step + 1;
    for (std::uint64_t i = 0; i < count; ++i) {
      if (!run_steps(body, body + step->body, static_cast<std::uint32_t>(src_first + i * step->src_stride),
                     static_cast<std::uint32_t>(dst_first + i * step->dst_stride), state)) {
        return false;
      }
    }
    return true;
  }

  bool run_steps(const Step* first, const Step* last, std::uint32_t src_frame, std::uint32_t dst_frame,
                 State& state) const noexcept {
    for (const Step* step = first; step != last; step += 1 + step->body) {
      const std::byte* src = state.source + src_frame + step->src;
      std::byte* dst = state.target + dst_frame + step->dst;
      switch (step->op) {
        case Op::zero: std::memset(dst, 0, step->size); break;
        case Op::copy:
          // Single fields are the common case after a reordering: fixed-size copies inline.
          if (step->size == 8) {
            std::memcpy(dst, src, 8);
          } else if (step->size == 4) {
            std::memcpy(dst, src, 4);
          } else {
            std::memcpy(dst, src, step->size);
          }
          break;
        case Op::convert: step->convert(src, dst, step->count, step->src_stride, step->dst_stride); break;
        case Op::scale:
          step->scaled(src, dst, step->count, step->src_stride, step->dst_stride, step->scale, step->offset);
          break;
        case Op::enum_map: {
          const std::int32_t value = load<std::int32_t>(src);
          const std::int32_t* pairs = enum_pairs_.data() + step->pool;
          // Pairs are sorted by source value: binary search over pool_count pairs.
          std::uint32_t low = 0;
          std::uint32_t high = step->pool_count;
          while (low < high) {
            const std::uint32_t middle = (low + high) / 2;
            if (pairs[2 * middle] < value) {
              low = middle + 1;
            } else {
              high = middle;
            }
          }
          if (low == step->pool_count || pairs[2 * low] != value) return false;  // not an enumerator
          store(dst, pairs[2 * low + 1]);
          break;
        }
        case Op::constant: std::memcpy(dst, constants_.data() + step->pool, step->size); break;
        case Op::tail_constant: {
          std::uint32_t at = 0;
          if (!reserve_tail(state, std::uint64_t{step->pool_count} + 1, 1, at)) return false;
          std::memcpy(state.target + at, constants_.data() + step->pool, step->pool_count);
          state.target[at + step->pool_count] = std::byte{0};
          store(dst, FlatSpan{at, step->pool_count});
          break;
        }
        case Op::string:
          if (!run_string(*step, src, dst, state)) return false;
          break;
        case Op::sequence:
          if (!run_sequence(step, src, dst, dst_frame, state)) return false;
          break;
        case Op::repeat: {
          const Step* body = step + 1;
          for (std::uint32_t i = 0; i < step->count; ++i) {
            if (!run_steps(body, body + step->body, src_frame + step->src + i * step->src_stride,
                           dst_frame + step->dst + i * step->dst_stride, state)) {
              return false;
            }
          }
          break;
        }
        case Op::transform:
          step->transform(src, dst, numbers_.data() + step->pool, elements_.data() + step->elements);
          break;
      }
    }
    return true;
  }

  void describe_steps(std::size_t first, std::size_t last, int depth, std::vector<std::string>& lines) const {
    const std::string indent(static_cast<std::size_t>(depth) * 2, ' ');
    for (std::size_t i = first; i < last; i += 1 + steps_[i].body) {
      const Step& step = steps_[i];
      if (step.op == Op::copy) {
        // Copies are merged at compile time; their note is the list of what they carry.
        lines.push_back(indent + "copy " + std::to_string(step.size) + " bytes @" + std::to_string(step.src) +
                        " -> @" + std::to_string(step.dst) + " (" + notes_[i] + ")");
      } else {
        lines.push_back(indent + notes_[i]);
      }
      if (steps_[i].body > 0) describe_steps(i + 1, i + 1 + steps_[i].body, depth + 1, lines);
    }
  }
};

// ---------------------------------------------------------------------------------------
// Paths: "a.b[1].c"

struct PathPart {
  std::string name;  // empty for an index
  std::uint32_t index = 0;
};

bool is_name_start(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_'; }
bool is_name_char(char c) { return is_name_start(c) || (c >= '0' && c <= '9'); }

std::optional<std::vector<PathPart>> parse_path(std::string_view text) {
  std::vector<PathPart> parts;
  std::size_t i = 0;
  bool expect_name = true;
  while (i < text.size() || expect_name) {
    if (expect_name) {
      if (i >= text.size() || !is_name_start(text[i])) return std::nullopt;
      const std::size_t start = i;
      while (i < text.size() && is_name_char(text[i])) ++i;
      parts.push_back({std::string(text.substr(start, i - start)), 0});
      expect_name = false;
    } else if (text[i] == '.') {
      ++i;
      expect_name = true;
    } else if (text[i] == '[') {
      const std::size_t start = ++i;
      while (i < text.size() && text[i] >= '0' && text[i] <= '9') ++i;
      std::uint32_t index = 0;
      const auto [end, ec] = std::from_chars(text.data() + start, text.data() + i, index);
      if (ec != std::errc{} || end != text.data() + i || i >= text.size() || text[i] != ']') {
        return std::nullopt;
      }
      ++i;
      parts.push_back({std::string(), index});
    } else {
      return std::nullopt;
    }
  }
  return parts;
}

std::string join_path(const std::string& parent, const std::string& name) {
  return parent.empty() ? name : parent + "." + name;
}

std::string index_path(const std::string& parent, std::uint32_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

std::string in_quotes(std::string_view text) { return "'" + std::string(text) + "'"; }

std::string join(const std::vector<std::string>& items, std::string_view separator) {
  std::string out;
  for (const auto& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::string field_list(const Type& type) {
  std::vector<std::string> names;
  for (const Field& field : type.fields) names.push_back(field.name);
  return names.empty() ? "none" : join(names, ", ");
}

std::string number_text(double value) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

// A field of one side, at a known place in the current frame.
struct Place {
  const Type* type = nullptr;  // resolved; null: there is none
  std::uint32_t offset = 0;
  std::string path;            // as the user reads it ("pose.x", "items[].x")
};

// How the fields under one node are mapped.
struct Options {
  const MappingRule* rule = nullptr;  // whose fault a problem is; null: the types'
  bool required = true;               // a target field without a source is an error
  bool allow_narrowing = false;
  bool truncate = false;
  bool scaled = false;                // scale/offset/units given
  double scale = 1.0;
  double offset = 0.0;
};

// A rule with its paths resolved.
struct PreparedRule {
  const MappingRule* rule = nullptr;
  std::string target_path;  // canonical
  Place target;
  Place source;             // copy / transform
  Options options;
  bool ok = false;          // false: its problems are reported, its target is left alone
};

// Whether path `inner` names a part of what path `outer` names ("a.b" and "a[1]" are in "a").
bool is_inside(const std::string& outer, const std::string& inner) {
  return inner.size() > outer.size() && inner.compare(0, outer.size(), outer) == 0 &&
         (inner[outer.size()] == '.' || inner[outer.size()] == '[');
}

struct Emitted {
  Step step;
  std::string note;
};

class Compiler {
 public:
  Compiler(const Type& from, const Type& to, const MappingSpec& spec, std::vector<MappingProblem>& problems)
      : from_(from), to_(to), spec_(spec), problems_(problems) {}

  std::unique_ptr<MappingProgram> compile() {
    const std::size_t problems_before = problems_.size();
    program_ = std::make_unique<CompiledMapping>();
    program_->source_fixed_ = from_.resolved().size;
    program_->target_fixed_ = to_.resolved().size;
    prepare_rules();

    Place root{&from_.resolved(), 0, ""};
    Options options;
    options.required = spec_.by_name;
    if (!spec_.by_name) root.type = nullptr;
    std::vector<Emitted> steps;
    out_ = &steps;
    // The root always has a source when one is required (by_name), so node() cannot report
    // it missing.
    node(to_.resolved(), 0, "", root, options);
    finalize(steps, program_->target_fixed_);
    if (problems_.size() != problems_before) return nullptr;
    for (Emitted& emitted : steps) {
      program_->steps_.push_back(emitted.step);
      program_->notes_.push_back(std::move(emitted.note));
    }
    return std::move(program_);
  }

 private:
  void problem(const MappingRule* rule, std::string message) {
    problems_.push_back(MappingProblem{rule, std::move(message)});
  }

  void emit(Step step, std::string note) { out_->push_back(Emitted{step, std::move(note)}); }

  static std::string label(const std::string& path) { return path.empty() ? "(sample)" : path; }

  std::string pair_text(const Place& source, const Place& target_place) const {
    return "source " + in_quotes(label(source.path)) + " (" + in_quotes(source.type->name) + ") to target " +
           in_quotes(label(target_place.path)) + " (" + in_quotes(target_place.type->name) + ")";
  }

  static std::string arrow(const std::string& source, const std::string& target) {
    if (source.empty() && target.empty()) return "the whole sample";
    if (source == target) return label(target);
    return label(source) + " -> " + label(target);
  }

  // -- rules ------------------------------------------------------------------------------

  // Resolves a path through structs and fixed arrays; reports and returns nothing if it
  // does not lead to a field.
  std::optional<Place> resolve(const MappingRule& rule, const Type& root, const std::string& text,
                               std::string_view side, std::string* canonical) {
    const auto parts = parse_path(text);
    if (!parts) {
      problem(&rule, "bad " + std::string(side) + " path " + in_quotes(text) +
                         " (expected names and [index], e.g. a.b[1].c)");
      return std::nullopt;
    }
    Place place{&root.resolved(), 0, ""};
    for (const PathPart& part : *parts) {
      const Type& type = *place.type;
      const std::string at = place.path;
      const auto not_found = [&](const std::string& why) {
        problem(&rule, std::string(side) + " " + in_quotes(text) + " not found in " + in_quotes(root.name) + " (" +
                           why + ")");
      };
      if (!part.name.empty()) {
        place.path = join_path(at, part.name);
        if (type.kind != TypeKind::structure) {
          not_found(in_quotes(at) + " is " + in_quotes(type.name) + ", which has no fields");
          return std::nullopt;
        }
        const Field* field = type.find_field(part.name);
        if (field == nullptr) {
          not_found((at.empty() ? std::string("fields: ") : "fields of " + in_quotes(at) + ": ") + field_list(type));
          return std::nullopt;
        }
        place.type = &field->type->resolved();
        place.offset += field->offset;
      } else {
        place.path = index_path(at, part.index);
        if (type.kind != TypeKind::array) {
          not_found(in_quotes(at) + " is " + in_quotes(type.name) + "; an index needs a fixed array");
          return std::nullopt;
        }
        if (part.index >= type.bound) {
          not_found(in_quotes(at) + " is " + in_quotes(type.name));
          return std::nullopt;
        }
        place.type = &type.element->resolved();
        place.offset += part.index * type.element->size;
      }
    }
    if (canonical != nullptr) *canonical = place.path;
    return place;
  }

  void prepare_rules() {
    for (const MappingRule& rule : spec_.rules) {
      PreparedRule prepared;
      prepared.rule = &rule;
      const auto target = resolve(rule, to_, rule.target, "target", &prepared.target_path);
      if (!target) continue;  // its target is unknown: nothing to leave alone either
      prepared.target = *target;
      prepared.ok = true;
      if (rule.kind != MappingRule::Kind::constant) {
        if (rule.source.empty()) {
          problem(&rule, "rule for target " + in_quotes(prepared.target_path) + " has no source");
          prepared.ok = false;
        } else if (const auto source = resolve(rule, from_, rule.source, "source", nullptr)) {
          prepared.source = *source;
        } else {
          prepared.ok = false;
        }
      }
      prepared.options.rule = &rule;
      prepared.options.required = true;
      prepared.options.allow_narrowing = rule.allow_narrowing;
      prepared.options.truncate = rule.truncate;
      if (!prepare_scale(rule, prepared.options)) prepared.ok = false;
      for (const PreparedRule& other : rules_) {
        if (other.target_path == prepared.target_path) {
          problem(&rule, "duplicate rule for target " + in_quotes(prepared.target_path) +
                             (other.rule->where.line > 0
                                  ? ": already given at line " + std::to_string(other.rule->where.line)
                                  : std::string()));
          prepared.ok = false;
          break;
        }
      }
      rules_.push_back(std::move(prepared));
    }
    // A rule inside the target of another is fine only when the outer one is a plain copy
    // of a struct or array: the inner one then overrides that part of it.
    for (PreparedRule& inner : rules_) {
      for (const PreparedRule& outer : rules_) {
        if (!is_inside(outer.target_path, inner.target_path)) continue;
        const bool plain = outer.rule->kind == MappingRule::Kind::copy && !outer.options.scaled;
        if (!plain) {
          problem(inner.rule, "rule for target " + in_quotes(inner.target_path) + " is inside " +
                                  in_quotes(outer.target_path) + ", which " +
                                  (outer.rule->where.line > 0
                                       ? "the rule at line " + std::to_string(outer.rule->where.line)
                                       : std::string("another rule")) +
                                  " sets as a whole");
          inner.ok = false;
        }
      }
    }
  }

  // Folds the unit conversion and then scale and offset into one y = x * scale + offset.
  bool prepare_scale(const MappingRule& rule, Options& options) {
    double scale = 1.0;
    double offset = 0.0;
    const bool has_units = !rule.from_unit.empty() || !rule.to_unit.empty();
    if (has_units) {
      if (rule.from_unit.empty() || rule.to_unit.empty()) {
        problem(&rule, "from_unit and to_unit go together");
        return false;
      }
      const Unit* from = find_unit(rule.from_unit);
      const Unit* to = find_unit(rule.to_unit);
      for (const auto& [unit, name] : {std::pair{from, &rule.from_unit}, std::pair{to, &rule.to_unit}}) {
        if (unit == nullptr) problem(&rule, "unknown unit " + in_quotes(*name) + " (known: " + known_units() + ")");
      }
      if (from == nullptr || to == nullptr) return false;
      if (from->dimension != to->dimension) {
        problem(&rule, "cannot convert " + in_quotes(from->name) + " (" + std::string(from->dimension) + ") to " +
                           in_quotes(to->name) + " (" + std::string(to->dimension) + ")");
        return false;
      }
      scale = from->factor / to->factor;
      offset = (from->offset - to->offset) / to->factor;
    }
    options.scaled = has_units || rule.scale != 1.0 || rule.offset != 0.0;
    options.scale = scale * rule.scale;
    options.offset = offset * rule.scale + rule.offset;
    if (!std::isfinite(options.scale) || !std::isfinite(options.offset)) {
      problem(&rule, "scale and offset must be finite numbers");
      return false;
    }
    if (options.scaled && rule.kind != MappingRule::Kind::copy) {
      problem(&rule, "scale, offset and units apply to copies, not to a " +
                         std::string(rule.kind == MappingRule::Kind::constant ? "constant" : "transform"));
      return false;
    }
    return true;
  }

  const PreparedRule* exact(const std::string& path) const {
    for (const PreparedRule& rule : rules_) {
      if (rule.target_path == path) return &rule;
    }
    return nullptr;
  }

  bool has_rules_below(const std::string& path) const {
    // Rules already found at fault do not count: descending for them would only report
    // the fields around them as unmapped.
    return std::any_of(rules_.begin(), rules_.end(), [&](const PreparedRule& rule) {
      return rule.ok && (path.empty() || is_inside(path, rule.target_path));
    });
  }

  // -- the walk ----------------------------------------------------------------------------

  // Maps one target node of the sample's own frame, where rules apply. Returns false when
  // the node needs a source and has none (the caller reports those together).
  bool node(const Type& target, std::uint32_t target_offset, const std::string& target_path,
            const Place& source, const Options& options) {
    const Place target_place{&target, target_offset, target_path};
    const bool below = has_rules_below(target_path);
    if (const PreparedRule* rule = exact(target_path)) {
      if (!rule->ok) return true;  // reported already
      if (!below) {
        apply_rule(*rule, target_place);
        return true;
      }
      descend(target_place, rule->source, rule->options);  // a rename with finer rules inside
      return true;
    }
    if (below) {
      descend(target_place, source, options);
      return true;
    }
    if (source.type == nullptr) return !options.required;
    map_value(source, target_place, options);
    return true;
  }

  // The fields (or elements) of a target struct (or array) with rules below it.
  void descend(const Place& target, const Place& source, const Options& options) {
    std::vector<std::string> missing;
    if (target.type->kind == TypeKind::structure) {
      for (const Field& field : target.type->fields) {
        const std::string path = join_path(target.path, field.name);
        if (!node(field.type->resolved(), target.offset + field.offset, path, field_of(source, field.name), options)) {
          missing.push_back(path);
        }
      }
    } else {  // an array: a rule path can only go through structs and arrays
      const Type& element = target.type->element->resolved();
      for (std::uint32_t i = 0; i < target.type->bound; ++i) {
        const std::string path = index_path(target.path, i);
        if (!node(element, target.offset + i * element.size, path, element_of(source, i), options)) {
          missing.push_back(path);
        }
      }
    }
    report_missing(missing, source, options);
  }

  static Place field_of(const Place& parent, const std::string& name) {
    Place child;
    child.path = join_path(parent.path, name);
    if (parent.type != nullptr && parent.type->kind == TypeKind::structure) {
      if (const Field* field = parent.type->find_field(name)) {
        child.type = &field->type->resolved();
        child.offset = parent.offset + field->offset;
      }
    }
    return child;
  }

  static Place element_of(const Place& parent, std::uint32_t index) {
    Place child;
    child.path = index_path(parent.path, index);
    if (parent.type != nullptr && parent.type->kind == TypeKind::array && index < parent.type->bound) {
      child.type = &parent.type->element->resolved();
      child.offset = parent.offset + index * parent.type->element->size;
    }
    return child;
  }

  void report_missing(const std::vector<std::string>& missing, const Place& source, const Options& options) {
    if (missing.empty()) return;
    std::vector<std::string> names;
    for (const auto& name : missing) names.push_back(in_quotes(name));
    std::string why;
    if (source.type == nullptr) {
      why = "no source field " + in_quotes(source.path);
    } else if (source.type->kind == TypeKind::structure) {
      why = (source.path.empty() ? std::string("source fields: ") : "fields of source " + in_quotes(source.path) + ": ") +
            field_list(*source.type);
    } else {
      why = "source " + in_quotes(label(source.path)) + " is " + in_quotes(source.type->name);
    }
    problem(options.rule, std::string(missing.size() == 1 ? "target field " : "target fields ") + join(names, ", ") +
                              " of " + in_quotes(to_.name) + (missing.size() == 1 ? " has" : " have") +
                              " no source in " + in_quotes(from_.name) + " (" + why + ")");
  }

  void apply_rule(const PreparedRule& rule, const Place& target) {
    switch (rule.rule->kind) {
      case MappingRule::Kind::copy: map_value(rule.source, target, rule.options); return;
      case MappingRule::Kind::constant: map_constant(*rule.rule, target); return;
      case MappingRule::Kind::linear:
      case MappingRule::Kind::affine: map_transform(*rule.rule, rule.source, target); return;
    }
  }

  // Whether a source of type `s` can be copied byte for byte into `t`: the same layout of
  // the same fields, nothing that needs checking on the way (bounded strings and sequences
  // carry lengths that must be checked, enums of other types translate).
  static bool same_bytes(const Type& s, const Type& t) {
    if (&s == &t) return plain(s);
    if (s.kind != t.kind || s.size != t.size) return false;
    if (s.is_primitive()) return true;
    switch (s.kind) {
      case TypeKind::array: return s.bound == t.bound && same_bytes(s.element->resolved(), t.element->resolved());
      case TypeKind::structure:
        if (s.fields.size() != t.fields.size()) return false;
        for (std::size_t i = 0; i < s.fields.size(); ++i) {
          if (s.fields[i].name != t.fields[i].name || s.fields[i].offset != t.fields[i].offset ||
              !same_bytes(s.fields[i].type->resolved(), t.fields[i].type->resolved())) {
            return false;
          }
        }
        return true;
      default: return false;
    }
  }

  static bool plain(const Type& type) {
    switch (type.kind) {
      case TypeKind::string:
      case TypeKind::sequence: return false;
      case TypeKind::array: return plain(type.element->resolved());
      case TypeKind::structure:
        return std::all_of(type.fields.begin(), type.fields.end(),
                           [](const Field& field) { return plain(field.type->resolved()); });
      default: return true;
    }
  }

  // Maps a whole source value onto a whole target value, recursively and by name; no rules
  // apply below this point.
  void map_value(const Place& source, const Place& target, const Options& options) {
    const Type& s = *source.type;
    const Type& t = *target.type;
    if (options.scaled && !number_kind(t.kind) && !(t.kind == TypeKind::array || t.kind == TypeKind::sequence)) {
      problem(options.rule, "scale, offset and units apply to numbers: target " + in_quotes(label(target.path)) +
                                " is " + in_quotes(t.name));
      return;
    }
    if (!options.scaled && same_bytes(s, t)) {
      Step step;
      step.op = Op::copy;
      step.src = source.offset;
      step.dst = target.offset;
      step.size = t.size;
      emit(step, arrow(source.path, target.path));
      return;
    }
    const auto s_number = number_kind(s.kind);
    const auto t_number = number_kind(t.kind);
    if (s_number && t_number) {
      map_numbers(source, target, *s_number, *t_number, 1, options);
      return;
    }
    const auto cannot = [&](const std::string& detail) {
      problem(options.rule, "cannot map " + pair_text(source, target) + (detail.empty() ? "" : ": " + detail));
    };
    if (s.kind != t.kind) {
      cannot("");
      return;
    }
    switch (t.kind) {
      case TypeKind::enumeration: map_enum(source, target, options); return;
      case TypeKind::string: map_string(source, target, options); return;
      case TypeKind::array: map_array(source, target, options); return;
      case TypeKind::sequence: map_sequence(source, target, options); return;
      case TypeKind::structure: map_struct(source, target, options); return;
      default: cannot(""); return;  // boolean and char only map to themselves (same_bytes)
    }
  }

  void map_numbers(const Place& source, const Place& target, Num s, Num t, std::uint32_t count,
                   const Options& options) {
    // Scaled values are computed in double: into an integer that rounds.
    const bool narrowing = options.scaled ? (!is_float(t) || !widens(s, t)) : !widens(s, t);
    if (narrowing && !options.allow_narrowing) {
      problem(options.rule, "narrowing " + pair_text(source, target) + " needs allow_narrowing=\"true\"" +
                                (options.scaled ? " (scaled values are computed as double)" : ""));
      return;
    }
    Step step;
    step.src = source.offset;
    step.dst = target.offset;
    step.count = count;
    step.src_stride = number_size(s);
    step.dst_stride = number_size(t);
    step.size = number_size(t);
    const std::string note = arrow(source.path, target.path);
    const std::string types = std::string(kind_name(scalar_kind(s))) + " -> " + std::string(kind_name(scalar_kind(t)));
    const std::string times = count > 1 ? " x" + std::to_string(count) : "";
    if (options.scaled) {
      step.op = Op::scale;
      step.scale = options.scale;
      step.offset = options.offset;
      step.scaled = pick_scaler(s, t);
      emit(step, "scale " + types + times + ": y = x * " + number_text(options.scale) + " + " +
                     number_text(options.offset) + " @" + std::to_string(step.src) + " -> @" +
                     std::to_string(step.dst) + " (" + note + ")");
    } else if (s == t) {
      step.op = Op::copy;
      step.size = count * number_size(t);
      emit(step, note);
    } else {
      step.op = Op::convert;
      step.convert = pick_converter(s, t);
      emit(step, "convert " + types + times + " @" + std::to_string(step.src) + " -> @" +
                     std::to_string(step.dst) + " (" + note + ")");
    }
  }

  static TypeKind scalar_kind(Num kind) {
    switch (kind) {
      case Num::i8: return TypeKind::int8;
      case Num::u8: return TypeKind::uint8;
      case Num::i16: return TypeKind::int16;
      case Num::u16: return TypeKind::uint16;
      case Num::i32: return TypeKind::int32;
      case Num::u32: return TypeKind::uint32;
      case Num::i64: return TypeKind::int64;
      case Num::u64: return TypeKind::uint64;
      case Num::f32: return TypeKind::float32;
      case Num::f64: break;
    }
    return TypeKind::float64;
  }

  void map_enum(const Place& source, const Place& target, const Options& options) {
    const Type& s = *source.type;
    const Type& t = *target.type;
    std::vector<std::pair<std::int32_t, std::int32_t>> pairs;
    std::vector<std::string> missing;
    for (const Enumerator& from : s.enumerators) {
      const auto to = std::find_if(t.enumerators.begin(), t.enumerators.end(),
                                   [&](const Enumerator& candidate) { return candidate.name == from.name; });
      if (to == t.enumerators.end()) {
        missing.push_back(in_quotes(from.name));
      } else {
        pairs.emplace_back(from.value, to->value);
      }
    }
    if (!missing.empty()) {
      problem(options.rule, "cannot map " + pair_text(source, target) + ": no enumerator " + join(missing, ", ") +
                                " in " + in_quotes(t.name));
      return;
    }
    std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    pairs.erase(std::unique(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                pairs.end());
    Step step;
    step.op = Op::enum_map;
    step.src = source.offset;
    step.dst = target.offset;
    step.pool = static_cast<std::uint32_t>(program_->enum_pairs_.size());
    step.pool_count = static_cast<std::uint32_t>(pairs.size());
    for (const auto& [from, to] : pairs) {
      program_->enum_pairs_.push_back(from);
      program_->enum_pairs_.push_back(to);
    }
    emit(step, "enum by name " + in_quotes(s.name) + " -> " + in_quotes(t.name) + " (" + std::to_string(pairs.size()) +
                   " values) @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
                   arrow(source.path, target.path) + ")");
  }

  static std::string bound_text(std::uint32_t bound) { return bound == 0 ? "unbounded" : "<=" + std::to_string(bound); }

  void map_string(const Place& source, const Place& target, const Options& options) {
    const Type& s = *source.type;
    const Type& t = *target.type;
    Step step;
    step.op = Op::string;
    step.src = source.offset;
    step.dst = target.offset;
    step.size = t.size;
    step.src_unbounded = s.bound == 0;
    step.dst_unbounded = t.bound == 0;
    step.src_bound = s.bound;
    step.dst_bound = t.bound;
    step.truncate = options.truncate;
    std::string note = "string " + bound_text(s.bound) + " -> " + bound_text(t.bound);
    if (t.bound == 0) note += ", into the target's tail";
    const bool may_overflow = t.bound != 0 && (s.bound == 0 || s.bound > t.bound);
    if (may_overflow) note += options.truncate ? ", cut if longer" : ", fails if longer";
    emit(step, note + " @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
                   arrow(source.path, target.path) + ")");
  }

  // Peels matching dimensions of two arrays: the innermost element types and the total count.
  static bool same_shape(const Type*& s, const Type*& t, std::uint32_t& count) {
    count = 1;
    while (s->kind == TypeKind::array && t->kind == TypeKind::array) {
      if (s->bound != t->bound) return false;
      count *= s->bound;
      s = &s->element->resolved();
      t = &t->element->resolved();
    }
    return true;
  }

  void map_array(const Place& source, const Place& target, const Options& options) {
    const Type& s = *source.type;
    const Type& t = *target.type;
    if (s.bound != t.bound) {
      problem(options.rule, "cannot map " + pair_text(source, target) + ": the lengths differ");
      return;
    }
    // Numbers in arrays of any dimension: one conversion over all of them.
    const Type* s_leaf = &s;
    const Type* t_leaf = &t;
    std::uint32_t count = 0;
    if (same_shape(s_leaf, t_leaf, count)) {
      const auto s_number = number_kind(s_leaf->kind);
      const auto t_number = number_kind(t_leaf->kind);
      if (s_number && t_number) {
        map_numbers(source, target, *s_number, *t_number, count, options);
        return;
      }
    }
    const Type& s_element = s.element->resolved();
    const Type& t_element = t.element->resolved();
    std::vector<Emitted> body;
    if (!compile_body(source, target, s_element, t_element, options, body)) return;
    Step step;
    step.op = Op::repeat;
    step.src = source.offset;
    step.dst = target.offset;
    step.count = t.bound;
    step.src_stride = s_element.size;
    step.dst_stride = t_element.size;
    step.body = static_cast<std::uint32_t>(body.size());
    emit(step, "for each of " + std::to_string(t.bound) + " elements @" + std::to_string(step.src) + " -> @" +
                   std::to_string(step.dst) + " (" + arrow(source.path, target.path) + "):");
    for (Emitted& emitted : body) out_->push_back(std::move(emitted));
  }

  // Compiles how one element maps, in its own frame. Returns false when it failed.
  bool compile_body(const Place& source, const Place& target, const Type& s_element, const Type& t_element,
                    const Options& options, std::vector<Emitted>& body) {
    const std::size_t before = problems_.size();
    std::vector<Emitted>* outer = out_;
    out_ = &body;
    map_value(Place{&s_element, 0, source.path + "[]"}, Place{&t_element, 0, target.path + "[]"}, options);
    out_ = outer;
    finalize(body, t_element.size);
    return problems_.size() == before;
  }

  void map_sequence(const Place& source, const Place& target, const Options& options) {
    const Type& s = *source.type;
    const Type& t = *target.type;
    const Type& s_element = s.element->resolved();
    const Type& t_element = t.element->resolved();
    std::vector<Emitted> body;
    if (!compile_body(source, target, s_element, t_element, options, body)) return;
    // Elements that copy whole need no per-element loop.
    if (body.size() == 1 && body[0].step.op == Op::copy && body[0].step.src == 0 && body[0].step.dst == 0 &&
        body[0].step.size == t_element.size && s_element.size == t_element.size) {
      body.clear();
    }
    Step step;
    step.op = Op::sequence;
    step.src = source.offset;
    step.dst = target.offset;
    step.size = t.size;
    step.src_unbounded = s.bound == 0;
    step.dst_unbounded = t.bound == 0;
    step.src_bound = s.bound;
    step.dst_bound = t.bound;
    step.src_first = static_cast<std::uint32_t>(align_up(sizeof(std::uint32_t), s_element.align));
    step.dst_first = static_cast<std::uint32_t>(align_up(sizeof(std::uint32_t), t_element.align));
    step.dst_align = t_element.align;
    step.src_stride = s_element.size;
    step.dst_stride = t_element.size;
    step.truncate = options.truncate;
    step.body = static_cast<std::uint32_t>(body.size());
    std::string note = "sequence " + bound_text(s.bound) + " -> " + bound_text(t.bound);
    if (t.bound == 0) note += ", into the target's tail";
    const bool may_overflow = t.bound != 0 && (s.bound == 0 || s.bound > t.bound);
    if (may_overflow) note += options.truncate ? ", cut if longer" : ", fails if longer";
    note += " @" + std::to_string(step.src) + " -> @" + std::to_string(step.dst) + " (" +
            arrow(source.path, target.path) + ")";
    emit(step, note + (body.empty() ? ", elements copied whole" : ", per element:"));
    for (Emitted& emitted : body) out_->push_back(std::move(emitted));
  }

  void map_struct(const Place& source, const Place& target, const Options& options) {
    std::vector<std::string> missing;
    for (const Field& field : target.type->fields) {
      const Place child = field_of(source, field.name);
      const Place target_child{&field.type->resolved(), target.offset + field.offset,
                               join_path(target.path, field.name)};
      if (child.type == nullptr) {
        missing.push_back(target_child.path);
        continue;
      }
      map_value(child, target_child, options);
    }
    report_missing(missing, source, options);
  }

  // -- constants ---------------------------------------------------------------------------

  void map_constant(const MappingRule& rule, const Place& target) {
    const Type& t = *target.type;
    const std::string& text = rule.value;
    const std::string what = "target " + in_quotes(target.path) + " (" + in_quotes(t.name) + ")";
    std::vector<std::byte> bytes;
    const auto put = [&bytes](const auto& value) {
      const auto* first = reinterpret_cast<const std::byte*>(&value);
      bytes.assign(first, first + sizeof value);
    };
    const auto bad = [&](const std::string& why) {
      problem(&rule, "bad constant " + in_quotes(text) + " for " + what + (why.empty() ? "" : ": " + why));
    };
    if (const auto kind = number_kind(t.kind)) {
      const bool ok = with_number(*kind, [&](auto type_tag) {
        using T = typename decltype(type_tag)::type;
        if constexpr (std::is_integral_v<T>) {
          std::int64_t signed_value = 0;
          std::uint64_t unsigned_value = 0;
          const char* first = text.data();
          const char* last = first + text.size();
          if (first != last && *first == '+' && last - first > 1 && first[1] != '-') ++first;
          const bool negative = first != last && *first == '-';
          const auto [end, ec] = negative ? std::from_chars(first, last, signed_value)
                                          : std::from_chars(first, last, unsigned_value);
          if (first == last || end != last || ec == std::errc::invalid_argument) {
            bad("expected an integer");
            return false;
          }
          const bool fits = ec == std::errc{} &&
                            (negative ? std::in_range<T>(signed_value) : std::in_range<T>(unsigned_value));
          if (!fits) {
            problem(&rule, "constant " + in_quotes(text) + " is out of range for " + what);
            return false;
          }
          put(negative ? static_cast<T>(signed_value) : static_cast<T>(unsigned_value));
          return true;
        } else {
          double value = 0.0;
          const char* first = text.data();
          const char* last = first + text.size();
          if (first != last && *first == '+') ++first;
          const auto [end, ec] = std::from_chars(first, last, value);
          if (first == last || end != last || ec != std::errc{} || !std::isfinite(value)) {
            bad("expected a finite number");
            return false;
          }
          if (std::abs(value) > static_cast<double>(std::numeric_limits<T>::max())) {
            problem(&rule, "constant " + in_quotes(text) + " is out of range for " + what);
            return false;
          }
          put(static_cast<T>(value));
          return true;
        }
      });
      if (!ok) return;
    } else if (t.kind == TypeKind::boolean) {
      if (text != "true" && text != "false" && text != "1" && text != "0") {
        bad("expected true, false, 1 or 0");
        return;
      }
      put(static_cast<std::uint8_t>(text == "true" || text == "1"));
    } else if (t.kind == TypeKind::char8) {
      if (text.size() != 1) {
        bad("expected one character");
        return;
      }
      put(text[0]);
    } else if (t.kind == TypeKind::enumeration) {
      // "NAME", or qualified as the IDL would ("Color::NAME", "::m::Color::NAME").
      std::string_view name = text;
      if (const auto colon = name.rfind("::"); colon != std::string_view::npos) {
        const std::string_view scope = name.substr(0, colon);
        std::string_view type_name = t.name;
        std::string_view scope_tail = scope.starts_with("::") ? scope.substr(2) : scope;
        if (!(type_name == scope_tail || type_name.ends_with("::" + std::string(scope_tail)))) name = {};
        else name = name.substr(colon + 2);
      }
      const auto match = std::find_if(t.enumerators.begin(), t.enumerators.end(),
                                      [&](const Enumerator& e) { return e.name == name; });
      if (match == t.enumerators.end()) {
        std::vector<std::string> names;
        for (const Enumerator& e : t.enumerators) names.push_back(e.name);
        problem(&rule, in_quotes(text) + " is not an enumerator of " + in_quotes(t.name) + " (enumerators: " +
                           join(names, ", ") + ")");
        return;
      }
      put(match->value);
    } else if (t.kind == TypeKind::string) {
      const std::size_t before = program_->constants_.size();
      const auto* chars = reinterpret_cast<const std::byte*>(text.data());
      Step step;
      step.dst = target.offset;
      step.pool = static_cast<std::uint32_t>(before);
      if (t.bound == 0) {
        program_->constants_.insert(program_->constants_.end(), chars, chars + text.size());
        step.op = Op::tail_constant;
        step.pool_count = static_cast<std::uint32_t>(text.size());
        emit(step, "constant " + in_quotes(text) + " into the target's tail (" + target.path + ")");
        return;
      }
      if (text.size() > t.bound) {
        problem(&rule, "constant of " + std::to_string(text.size()) + " characters does not fit " + what);
        return;
      }
      bytes.assign(chars, chars + text.size());
      bytes.resize(t.size, std::byte{0});  // NUL and the unused rest
    } else {
      problem(&rule, "a constant needs a number, boolean, char, enum or string target; " + in_quotes(target.path) +
                         " is " + in_quotes(t.name));
      return;
    }
    Step step;
    step.op = Op::constant;
    step.dst = target.offset;
    step.size = static_cast<std::uint32_t>(bytes.size());
    step.pool = static_cast<std::uint32_t>(program_->constants_.size());
    program_->constants_.insert(program_->constants_.end(), bytes.begin(), bytes.end());
    emit(step, "constant " + in_quotes(text) + " -> @" + std::to_string(step.dst) + " (" + target.path + ")");
  }

  // -- transforms --------------------------------------------------------------------------

  // A vector field: a fixed array of 1..6 numbers, or a struct of 1..6 numeric fields in
  // declaration order.
  static std::optional<std::vector<VectorElement>> vector_elements(const Place& place) {
    const Type& type = *place.type;
    std::vector<VectorElement> elements;
    if (type.kind == TypeKind::array) {
      const auto kind = number_kind(type.element->resolved().kind);
      if (!kind) return std::nullopt;
      for (std::uint32_t i = 0; i < type.bound; ++i) {
        elements.push_back({*kind, place.offset + i * type.element->size});
      }
    } else if (type.kind == TypeKind::structure) {
      for (const Field& field : type.fields) {
        const auto kind = number_kind(field.type->resolved().kind);
        if (!kind) return std::nullopt;
        elements.push_back({*kind, place.offset + field.offset});
      }
    } else {
      return std::nullopt;
    }
    if (elements.empty() || elements.size() > kMaxVector) return std::nullopt;
    return elements;
  }

  void map_transform(const MappingRule& rule, const Place& source, const Place& target) {
    const bool affine = rule.kind == MappingRule::Kind::affine;
    const auto source_elements = vector_elements(source);
    const auto target_elements = vector_elements(target);
    const std::string vector_text =
        " is not a vector field (a fixed array of 1 to 6 numbers, or a struct of 1 to 6 numeric fields)";
    if (!source_elements) {
      problem(&rule, "source " + in_quotes(source.path) + " (" + in_quotes(source.type->name) + ")" + vector_text);
    }
    if (!target_elements) {
      problem(&rule, "target " + in_quotes(target.path) + " (" + in_quotes(target.type->name) + ")" + vector_text);
    }
    if (!source_elements || !target_elements) return;
    const auto rows = static_cast<std::uint32_t>(target_elements->size());
    const auto cols = static_cast<std::uint32_t>(source_elements->size());
    std::uint32_t given_rows = rule.matrix_rows;
    std::uint32_t given_cols = rule.matrix_cols;
    if (given_rows == 0 && given_cols == 0 && rule.matrix.size() == std::size_t{rows} * cols) {
      given_rows = rows;  // built in code without dimensions: the entries must fit
      given_cols = cols;
    }
    bool ok = true;
    if (given_rows != rows || given_cols != cols) {
      problem(&rule, "matrix is " + std::to_string(given_rows) + "x" + std::to_string(given_cols) + ", but target " +
                         in_quotes(target.path) + " has " + std::to_string(rows) + " elements and source " +
                         in_quotes(source.path) + " has " + std::to_string(cols) + ": expected " +
                         std::to_string(rows) + "x" + std::to_string(cols));
      ok = false;
    } else if (rule.matrix.size() != std::size_t{rows} * cols) {
      problem(&rule, "matrix has " + std::to_string(rule.matrix.size()) + " entries; " + std::to_string(rows) + "x" +
                         std::to_string(cols) + " needs " + std::to_string(rows * cols));
      ok = false;
    }
    if (affine && rule.translation.size() != rows) {
      problem(&rule, "translation has " + std::to_string(rule.translation.size()) + " entries, but target " +
                         in_quotes(target.path) + " has " + std::to_string(rows) + " elements");
      ok = false;
    }
    if (!affine && !rule.translation.empty()) {
      problem(&rule, "a translation needs transform=\"affine\"");
      ok = false;
    }
    const bool all_double = std::all_of(target_elements->begin(), target_elements->end(),
                                        [](const VectorElement& e) { return e.kind == Num::f64; });
    if (!all_double && !rule.allow_narrowing) {
      problem(&rule, "a transform computes in double: writing target " + in_quotes(target.path) + " (" +
                         in_quotes(target.type->name) + ") is narrowing and needs allow_narrowing=\"true\"");
      ok = false;
    }
    const bool finite = std::all_of(rule.matrix.begin(), rule.matrix.end(), [](double v) { return std::isfinite(v); }) &&
                        std::all_of(rule.translation.begin(), rule.translation.end(),
                                    [](double v) { return std::isfinite(v); });
    if (!finite) {
      problem(&rule, "matrix and translation entries must be finite numbers");
      ok = false;
    }
    if (!ok) return;
    Step step;
    step.op = Op::transform;
    step.count = rows;
    step.pool_count = cols;
    step.pool = static_cast<std::uint32_t>(program_->numbers_.size());
    step.elements = static_cast<std::uint32_t>(program_->elements_.size());
    const bool doubles_in = std::all_of(source_elements->begin(), source_elements->end(),
                                        [](const VectorElement& e) { return e.kind == Num::f64; });
    step.transform = pick_kernel(static_cast<int>(rows), static_cast<int>(cols), affine, doubles_in && all_double);
    program_->numbers_.insert(program_->numbers_.end(), rule.matrix.begin(), rule.matrix.end());
    if (affine) program_->numbers_.insert(program_->numbers_.end(), rule.translation.begin(), rule.translation.end());
    program_->elements_.insert(program_->elements_.end(), source_elements->begin(), source_elements->end());
    program_->elements_.insert(program_->elements_.end(), target_elements->begin(), target_elements->end());
    emit(step, std::string(affine ? "affine" : "linear") + " " + std::to_string(rows) + "x" + std::to_string(cols) +
                   " transform (" + arrow(source.path, target.path) + ")");
  }

  // -- finishing a frame -------------------------------------------------------------------

  // Merges adjacent copies, then zeroes every byte of the frame no step writes (padding,
  // fields left unset), so run() never clears the whole sample first.
  void finalize(std::vector<Emitted>& steps, std::uint32_t frame_size) const {
    std::vector<Emitted> merged;
    for (std::size_t i = 0; i < steps.size();) {
      const std::size_t next = i + 1 + steps[i].step.body;
      if (steps[i].step.op == Op::copy && !merged.empty()) {
        Emitted& last = merged.back();
        const Step& step = steps[i].step;
        if (last.step.op == Op::copy && last.step.src + last.step.size == step.src &&
            last.step.dst + last.step.size == step.dst) {
          last.step.size += step.size;
          last.note += ", " + steps[i].note;
          i = next;
          continue;
        }
      }
      for (std::size_t k = i; k < next; ++k) merged.push_back(std::move(steps[k]));
      i = next;
    }
    std::vector<std::pair<std::uint64_t, std::uint64_t>> written;
    for (std::size_t i = 0; i < merged.size(); i += 1 + merged[i].step.body) {
      const Step& step = merged[i].step;
      switch (step.op) {
        case Op::zero:
        case Op::copy:
        case Op::constant:
        case Op::string:
        case Op::sequence: written.emplace_back(step.dst, step.dst + step.size); break;
        case Op::tail_constant: written.emplace_back(step.dst, step.dst + sizeof(FlatSpan)); break;
        case Op::enum_map: written.emplace_back(step.dst, step.dst + sizeof(std::int32_t)); break;
        case Op::convert:
        case Op::scale:
          for (std::uint32_t k = 0; k < step.count; ++k) {
            const std::uint64_t at = step.dst + std::uint64_t{k} * step.dst_stride;
            written.emplace_back(at, at + step.size);
          }
          break;
        case Op::repeat: written.emplace_back(step.dst, step.dst + std::uint64_t{step.count} * step.dst_stride); break;
        case Op::transform:
          for (std::uint32_t r = 0; r < step.count; ++r) {
            const VectorElement& element = program_->elements_[step.elements + step.pool_count + r];
            written.emplace_back(element.offset, element.offset + number_size(element.kind));
          }
          break;
      }
    }
    std::sort(written.begin(), written.end());
    std::vector<Emitted> result;
    std::uint64_t at = 0;
    const auto zero_until = [&](std::uint64_t end) {
      if (end <= at) return;
      Step step;
      step.op = Op::zero;
      step.dst = static_cast<std::uint32_t>(at);
      step.size = static_cast<std::uint32_t>(end - at);
      result.push_back(Emitted{step, "zero " + std::to_string(step.size) + " bytes @" + std::to_string(step.dst)});
    };
    for (const auto& [first, last] : written) {
      zero_until(std::min<std::uint64_t>(first, frame_size));
      at = std::max(at, last);
    }
    zero_until(frame_size);
    for (Emitted& emitted : merged) result.push_back(std::move(emitted));
    steps = std::move(result);
  }

  const Type& from_;
  const Type& to_;
  const MappingSpec& spec_;
  std::vector<MappingProblem>& problems_;
  std::vector<PreparedRule> rules_;
  std::unique_ptr<CompiledMapping> program_;
  std::vector<Emitted>* out_ = nullptr;
};

}  // namespace

std::unique_ptr<MappingProgram> MappingProgram::compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                        std::vector<MappingProblem>& problems) {
  return Compiler(from, to, spec, problems).compile();
}

std::unique_ptr<MappingProgram> MappingProgram::compile(const Type& from, const Type& to, const MappingSpec& spec,
                                                        Diagnostics& diagnostics) {
  std::vector<MappingProblem> problems;
  auto program = compile(from, to, spec, problems);
  for (const MappingProblem& item : problems) {
    if (item.rule != nullptr) {
      diagnostics.error(item.rule->where, item.rule->element_path, item.message);
    } else {
      diagnostics.error(spec.where, spec.element_path, item.message);
    }
  }
  return program;
}

}  // namespace polyport
