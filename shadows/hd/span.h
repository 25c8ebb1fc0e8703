// A POD view over contiguous memory, usable in CDSM_HD code (no STL there).
#pragma once

#include <cstddef>
#include <cstdint>
#include <type_traits>

#include "cdsm/config.h"

namespace cdsm {

template <class T>
struct Span {
  T* ptr = nullptr;
  uint64_t count = 0;

  constexpr Span() = default;
  CDSM_HD constexpr Span(T* p, uint64_t n) : ptr(p), count(n) {}
  // A span of T converts to a span of const T.
  template <class U>
  CDSM_HD constexpr Span(const Span<U>& o) : ptr(o.ptr), count(o.count) {}

  CDSM_HD constexpr uint64_t size() const { return count; }
  CDSM_HD constexpr bool empty() const { return count == 0; }
  CDSM_HD constexpr T* data() const { return ptr; }
  CDSM_HD constexpr T* begin() const { return ptr; }
  CDSM_HD constexpr T* end() const { return ptr + count; }
  CDSM_HD T& operator[](uint64_t i) const {
    CDSM_HD_ASSERT(i < count);
    return ptr[i];
  }
  CDSM_HD constexpr Span subspan(uint64_t first, uint64_t n) const { return Span(ptr + first, n); }
};

// Host helper: a span over any container with data() and size().
template <class C>
auto span_of(C& c) -> Span<std::remove_reference_t<decltype(*c.data())>> {
  return {c.data(), static_cast<uint64_t>(c.size())};
}

}  // namespace cdsm
