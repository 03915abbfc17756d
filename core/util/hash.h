// The 64-bit FNV-1a hash: a stable short name for a text (native code's library names, an FMU's
// guid). Not for security.
#pragma once

#include <cstdint>
#include <string_view>

namespace gb {

// FNV-1a of `bytes`, continuing from `h` (the offset basis for a first piece).
inline std::uint64_t Fnv1a(std::string_view bytes, std::uint64_t h = 0xcbf29ce484222325ULL) {
  for (const char c : bytes) h = (h ^ static_cast<unsigned char>(c)) * 0x100000001b3ULL;
  return h;
}

}  // namespace gb
