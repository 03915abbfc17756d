// Whether this build is instrumented by AddressSanitizer (scripts/sanitize.sh and the fuzz
// build). GCC defines __SANITIZE_ADDRESS__; clang answers __has_feature(address_sanitizer).
//
// Tests use kSanitized to run on smaller data under the sanitizers where their point there is
// the code path and not the statistics (each such test says so); the release suite always runs
// them in full. The workbench uses it to run LeakSanitizer's check before Mesa unloads its
// driver (app/greybench_main.cpp).
// -DGREYBENCH_ASAN=1 forces the sanitizers' variants of the tests in any build (to check them
// quickly in a release build).
#pragma once

#if defined(GREYBENCH_ASAN)
#elif defined(__SANITIZE_ADDRESS__)
#define GREYBENCH_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define GREYBENCH_ASAN 1
#endif
#endif
#ifndef GREYBENCH_ASAN
#define GREYBENCH_ASAN 0
#endif

namespace gb {
inline constexpr bool kSanitized = GREYBENCH_ASAN != 0;
}  // namespace gb
