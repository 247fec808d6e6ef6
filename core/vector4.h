#ifndef HETSLAM_CORE_VECTOR4_H_
#define HETSLAM_CORE_VECTOR4_H_

// Four floats or four 32-bit integers as one SSE register (GCC's and Clang's vector
// extensions), for hot loops that must give the same floats as their scalar form: each lane
// goes through the same operations in the same order, and the x86-64 baseline has no FMA to
// contract them (the build sets no -m flags).

#include <cstdint>
#include <cstring>

namespace hetslam {

using Floats4 = float __attribute__((vector_size(16)));
using Ints4 = int32_t __attribute__((vector_size(16)));

inline Floats4 Splat(float v) { return Floats4{v, v, v, v}; }
inline Ints4 Splat(int32_t v) { return Ints4{v, v, v, v}; }

// The four values from `p` (no alignment needed).
template <typename Vector, typename T>
inline Vector Load4(const T* p) {
  static_assert(sizeof(Vector) == 4 * sizeof(T), "four values a vector");
  Vector v;
  std::memcpy(&v, p, sizeof(v));
  return v;
}

}  // namespace hetslam

#endif  // HETSLAM_CORE_VECTOR4_H_
