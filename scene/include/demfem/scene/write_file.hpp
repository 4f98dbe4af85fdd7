// Checked, atomic whole-file writes for every output that is not a streamed time series (issue
// 13): the text goes to "<path>.<pid>.tmp", is flushed to the disk and renamed over path, so a
// reader sees either the old file or a complete new one, also when several processes (MPI ranks)
// write the same file. Any failure (a full disk, a file size limit,
// an unwritable directory) throws WriteError naming the file and the cause.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string_view>

namespace demfem::scene {

class WriteError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

void write_file_atomic(const std::filesystem::path& path, std::string_view text);

} // namespace demfem::scene
