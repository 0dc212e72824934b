#pragma once
// Whole-file writes that a reader (or a crash) sees either complete or not at all, and the small file
// helpers the result writers share. No other engine file opens result files for writing.
//
// A whole file is written to `<path>.tmp.<pid>` in the same folder and renamed over `<path>`. Errors throw
// std::runtime_error naming the path and the system's reason.
#include <filesystem>
#include <string>

namespace dem {

/// Writes `contents` to `path` + ".tmp.<pid>" and renames it over `path`. The folder must exist.
/// Throws std::runtime_error naming the path and errno text; on failure the temporary file is removed
/// and `path` is left as it was.
void write_file_atomically(const std::filesystem::path& path, const std::string& contents);

/// Reads the whole file into `contents`; false if it does not exist. Throws std::runtime_error on other
/// errors.
bool read_whole_file(const std::filesystem::path& path, std::string& contents);

/// Writes all of `size` bytes to the open descriptor `fd`, retrying partial writes and EINTR; returns 0 or
/// an errno value.
int write_all(int fd, const char* data, std::size_t size);

/// Throws std::runtime_error "<what> '<path>': <errno text>".
[[noreturn]] void throw_io(const std::string& what, const std::filesystem::path& path, int error);

}  // namespace dem
