#pragma once
// Version, git hash and flags of this build, set by engine/CMakeLists.txt for the `dem` program.
#ifndef DEM_VERSION
#define DEM_VERSION "0.0.0"
#endif
#ifndef DEM_GIT_HASH
#define DEM_GIT_HASH "unknown"
#endif
#ifndef DEM_COMPILE_FLAGS
#define DEM_COMPILE_FLAGS ""
#endif
