// CRC32C (Castagnoli), the checksum of every framed record graphslam writes
// (docs/formats/observation_chunk.md), after LevelDB's util/crc32c.h.
//
//   polynomial  0x1EDC6F41 (reflected: 0x82F63B78), init 0xFFFFFFFF,
//   final xor   0xFFFFFFFF; Value("123456789") = 0xE3069283 (RFC 3720 B.4)
//
// Extend(Value(a), b) == Value(a + b), so a checksum can be built piece by
// piece. A CRC stored next to the data it covers is masked (Mask below): the
// CRC of a string that itself contains CRCs is otherwise weak (LevelDB's
// rationale in crc32c.h), and a masked zero region is not a valid checksum.
//
//   Mask(c)   = ((c >> 15) | (c << 17)) + 0xA282EAD8      (mod 2^32)
//   Unmask(m) = rotate_left(m - 0xA282EAD8, 15) ... i.e. the inverse of Mask
//
// Debian 12 ships no C/C++ CRC32C library (apt has only python3-crc32c), so the
// code is ours: the SSE4.2 `crc32` instruction when the CPU has it (chosen once,
// at first use), otherwise slicing-by-8 tables (Intel, Kounavis & Berry 2005).
// Both give identical results; the tests check the RFC 3720 vectors.
//
// THREAD SAFETY: pure functions; safe from any thread. ALLOCATION: none (the
// tables are static constants).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace graphslam::storage::crc32c {

// The CRC32C of data[0, n) appended to a string whose CRC32C is `crc`.
uint32_t Extend(uint32_t crc, const char* data, size_t n);

// The CRC32C of data[0, n).
inline uint32_t Value(const char* data, size_t n) { return Extend(0, data, n); }
inline uint32_t Value(std::string_view data) { return Extend(0, data.data(), data.size()); }

inline constexpr uint32_t kMaskDelta = 0xA282EAD8u;

// The form in which a CRC is stored (see the header comment).
inline constexpr uint32_t Mask(uint32_t crc) { return ((crc >> 15) | (crc << 17)) + kMaskDelta; }
// Inverse of Mask.
inline constexpr uint32_t Unmask(uint32_t masked) {
  const uint32_t rotated = masked - kMaskDelta;
  return (rotated >> 17) | (rotated << 15);
}

// Extend through the portable tables only, whatever the CPU; tests compare it
// with Extend so both paths stay checked on machines that have SSE4.2.
uint32_t ExtendSoftware(uint32_t crc, const char* data, size_t n);

// True when Extend uses the SSE4.2 instruction (for benchmarks and reports).
bool IsHardwareAccelerated();

}  // namespace graphslam::storage::crc32c
