// A whole output file (a gnuplot script or data file, a table) built in memory and written by
// close() through the checked atomic write (issue 13): "<path>.tmp", flushed to the disk, renamed
// over path; a failure (a full disk, a file size limit, an unwritable directory) throws
// scene::WriteError naming the file and the cause, so no figure is drawn from a partial input.
// Nothing is written unless close() is called.
#pragma once

#include <filesystem>
#include <sstream>
#include <utility>

#include "demfem/scene/write_file.hpp"

namespace demfem::compare {

class OutFile : public std::ostringstream {
public:
  explicit OutFile(std::filesystem::path path) : path_(std::move(path)) {}
  void close() { scene::write_file_atomic(path_, str()); }

private:
  std::filesystem::path path_;
};

} // namespace demfem::compare
