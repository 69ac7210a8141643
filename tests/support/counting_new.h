#pragma once
// Test helper for one source file per test program: counts every allocation made through the
// global operator new, which this header replaces (so include it in one .cc only). A test reads
// multibond::testing::g_allocations before and after the code that must not allocate.

#include <atomic>
#include <cstdlib>
#include <new>

namespace multibond::testing {
inline std::atomic<long> g_allocations{0};
}  // namespace multibond::testing

// None inlined: GCC 12 would see an inlined malloc or free paired with a call of the other
// operator and warn (-Wmismatched-new-delete).
[[gnu::noinline]] void* operator new(std::size_t n) {
  ++multibond::testing::g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void* operator new[](std::size_t n) { return operator new(n); }
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
// The nothrow forms too (std::stable_sort's temporary buffer uses them): left to the library,
// they would allocate through the sanitizer's operator new and be freed here by free().
[[gnu::noinline]] void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  ++multibond::testing::g_allocations;
  return std::malloc(n ? n : 1);
}
[[gnu::noinline]] void* operator new[](std::size_t n, const std::nothrow_t& tag) noexcept {
  return operator new(n, tag);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
