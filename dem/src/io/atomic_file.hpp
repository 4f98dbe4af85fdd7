// Private helper of the DEM I/O layer: write a file under a temporary name, fsync, rename.
#pragma once

#include <cstddef>
#include <filesystem>
#include <span>
#include <string_view>

namespace demfem::dem::io::detail {

// Writes "<path>.tmp"; commit() fsyncs it, renames it over <path> and fsyncs the directory.
// Destroyed without commit() (an exception on the way), the temporary file is removed.
class AtomicFile {
public:
  explicit AtomicFile(std::filesystem::path path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::span<const std::byte> bytes);
  void write(std::string_view text);
  void commit();

private:
  std::filesystem::path path_;
  std::filesystem::path tmp_;
  int fd_ = -1;
};

// "<path>.tmp" next to path.
[[nodiscard]] std::filesystem::path temporary_path(const std::filesystem::path& path);

// Renames tmp over path (same directory), throwing IoError on failure.
void rename_over(const std::filesystem::path& tmp, const std::filesystem::path& path);

} // namespace demfem::dem::io::detail
