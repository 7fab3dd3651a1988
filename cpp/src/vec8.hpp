// A generic 8-float vector for the hot loops (blur.cpp, focal_stack.cpp): one AVX
// register in their AVX2 builds (hot_loop.hpp), two SSE registers in the baseline
// one; elsewhere LIFF_VEC8 is undefined and the loops take their scalar paths.
#pragma once

#include <cstring>

namespace liff {
namespace detail {

/// Floats per Vec8.
constexpr int kLanes = 8;

#if defined(__GNUC__) || defined(__clang__)
// The helpers are inlined; GCC's note that passing an AVX vector by value changes the
// ABI without AVX enabled concerns calls across files, which never happen.
#pragma GCC diagnostic ignored "-Wpsabi"
typedef float Vec8 __attribute__((vector_size(kLanes * sizeof(float))));
/// Unaligned load and store (memcpy compiles to one move).
inline Vec8 load(const float* p) {
  Vec8 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store(float* p, Vec8 v) { std::memcpy(p, &v, sizeof v); }
/// 16 floats: one AVX-512 register where the build has it, else two of Vec8's.
typedef float Vec16 __attribute__((vector_size(2 * kLanes * sizeof(float))));
inline Vec16 load16(const float* p) {
  Vec16 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store16(float* p, Vec16 v) { std::memcpy(p, &v, sizeof v); }
#define LIFF_VEC8 1
#endif

}  // namespace detail
}  // namespace liff
