#pragma once
// DEM_ASSERT: programmer mistakes, on in Debug and RelWithDebInfo builds (CMake defines DEM_ASSERT_ON).
// DEM_VALIDATE: costly invariants (sorted keys, CSR consistency, finite state), on with the
// DEM_VALIDATE CMake option; tests build with it.
#include <cstdio>
#include <cstdlib>

namespace dem::detail {
[[noreturn]] inline void check_failed(const char* kind, const char* expr, const char* file, int line) {
  std::fprintf(stderr, "%s failed: %s at %s:%d\n", kind, expr, file, line);
  std::abort();
}
}  // namespace dem::detail

#ifdef DEM_ASSERT_ON
#define DEM_ASSERT(expr) ((expr) ? (void)0 : ::dem::detail::check_failed("DEM_ASSERT", #expr, __FILE__, __LINE__))
#else
#define DEM_ASSERT(expr) ((void)0)
#endif

#ifdef DEM_VALIDATE_ON
#define DEM_VALIDATE(expr) ((expr) ? (void)0 : ::dem::detail::check_failed("DEM_VALIDATE", #expr, __FILE__, __LINE__))
#else
#define DEM_VALIDATE(expr) ((void)0)
#endif
