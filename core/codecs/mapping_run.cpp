// Running a compiled mapping (mapping_program.hpp): CompiledMapping::run() and its helpers.
//
// run() is the forwarding path. It runs on the thread of the writer that delivers a sample
// (Connection::deliver), reads the caller's source buffer and writes the caller's target
// buffer; it owns no buffer and touches no shared state other than the program, which is
// immutable after compile(), so one program may run on several threads at once. It does not
// allocate, lock or throw: every table it needs (enum pairs, constants, matrices, vector
// element lists) lives in vectors filled at compile time, and matrix products use Eigen
// fixed-size types chosen by a dispatch on (rows, cols).
//
// The number conversion kernels a step calls are in mapping_values.cpp, the matrix kernels in
// mapping_transforms.cpp; both are chosen at compile time and reached through the step.
#include "mapping_program.hpp"

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace polyport::mapping {

struct CompiledMapping::State {
  const std::byte* source;
  std::uint32_t source_size;
  std::byte* target;
  std::uint32_t capacity;
  std::uint32_t tail;  // the next free byte of the target's tail
};

bool CompiledMapping::run(const std::byte* source, std::uint32_t source_size, std::byte* target,
                          std::uint32_t target_capacity, std::uint32_t& target_size) const noexcept {
  if (source == nullptr || target == nullptr) return false;
  if (source_size < source_fixed_ || target_capacity < target_fixed_) return false;
  State state{source, source_size, target, target_capacity, target_fixed_};
  if (!run_steps(steps_.data(), steps_.data() + steps_.size(), 0, 0, state)) return false;
  target_size = state.tail;
  return true;
}

// Reserves `bytes` of the target's tail aligned to `alignment`, zeroing the alignment gap
// so equal inputs give equal bytes; returns its offset, or nothing when it does not fit.
inline bool CompiledMapping::reserve_tail(State& state, std::uint64_t bytes, std::uint32_t alignment,
                                          std::uint32_t& at) noexcept {
  const std::uint64_t start = align_up(state.tail, alignment);
  if (start > state.capacity || bytes > state.capacity - start) return false;
  std::memset(state.target + state.tail, 0, start - state.tail);
  at = static_cast<std::uint32_t>(start);
  state.tail = static_cast<std::uint32_t>(start + bytes);
  return true;
}

// A source span must lie inside the sample: `bytes` from `offset`.
inline bool CompiledMapping::span_fits(const State& state, std::uint64_t offset, std::uint64_t bytes) noexcept {
  return offset <= state.source_size && bytes <= state.source_size - offset;
}

inline bool CompiledMapping::run_string(const Step& step, const std::byte* src, std::byte* dst,
                                        State& state) const noexcept {
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

inline bool CompiledMapping::run_sequence(const Step* step, const std::byte* src, std::byte* dst,
                                          std::uint32_t dst_frame, State& state) const noexcept {
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

// An LCM length member from the element count of a target sequence of the same struct, which
// an earlier step of this frame has written: a bounded one holds its count first, an unbounded
// one in its FlatSpan. A count beyond the member's range fails rather than wrap (the LCM codec
// would refuse the sample anyway, with less to say); a second sequence sized by the same
// member must have the same count.
inline bool CompiledMapping::run_length(const Step& step, std::byte* dst, std::uint32_t dst_frame,
                                        State& state) noexcept {
  const std::byte* sequence = state.target + dst_frame + step.counted;
  const std::uint32_t count =
      step.dst_unbounded ? load<FlatSpan>(sequence).count : load<std::uint32_t>(sequence);
  if (count > step.dst_bound) return false;
  std::byte value[sizeof(std::uint64_t)];
  step.convert(reinterpret_cast<const std::byte*>(&count), value, 1, 0, 0);
  if (step.compare) return std::memcmp(value, dst, step.size) == 0;
  std::memcpy(dst, value, step.size);
  return true;
}

inline bool CompiledMapping::run_steps(const Step* first, const Step* last, std::uint32_t src_frame,
                                       std::uint32_t dst_frame, State& state) const noexcept {
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
      case Op::length:
        if (!run_length(*step, dst, dst_frame, state)) return false;
        break;
    }
  }
  return true;
}

}  // namespace polyport::mapping
