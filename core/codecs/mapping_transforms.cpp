// Linear and affine transforms, y = M x (+ t), on vector fields (mapping_compiler.hpp): a rule
// checked against its fields (vectors of 1 to 6 numbers, a matrix of their shape, finite
// entries, narrowing allowed where the target is not double) at load time, and the Eigen
// kernels its step calls. The kernels run on the forwarding path, on the thread and with the
// buffers of CompiledMapping::run() (mapping_run.cpp): no allocation, the vectors on the stack.
#include "mapping_compiler.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace polyport::mapping {

namespace {

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

// ---------------------------------------------------------------------------------------
// Matrix kernels: one instantiation per (rows, cols, affine), so the product is Eigen's
// fixed-size code (unrolled, on the stack) whatever the vector fields' element types.

constexpr int kMaxVector = 6;

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

}  // namespace

// -- transforms --------------------------------------------------------------------------

// A vector field: a fixed array of 1..6 numbers, or a struct of 1..6 numeric fields in
// declaration order.
std::optional<std::vector<VectorElement>> Compiler::vector_elements(const Place& place) {
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

void Compiler::map_transform(const MappingRule& rule, const Place& source, const Place& target) {
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

}  // namespace polyport::mapping
