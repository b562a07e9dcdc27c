// Writing output files so that a failure never leaves a half-written file:
// data goes to "<path>.tmp-<pid>" in the same folder, is flushed, then renamed.
#pragma once

#include <string>
#include <string_view>

namespace icube::scene {

// Throws std::runtime_error naming the path on any failure (the temporary is removed).
void write_file_atomic(const std::string& path, std::string_view bytes);

// Reads a whole file; throws InputError(path, "", reason) when it cannot.
std::string read_file(const std::string& path);

// Throws std::runtime_error when `output` exists and is the file or folder `input` (the same inode).
void refuse_overwriting_input(const std::string& input, const std::string& output);

}  // namespace icube::scene
