#include "demfem/scene/write_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include <fmt/format.h>

namespace demfem::scene {

void write_file_atomic(const std::filesystem::path& path, std::string_view text) {
  // one temporary per process: ranks of an MPI run (or study processes) that write the same file
  // each rename their own complete copy, and the last rename wins
  std::filesystem::path tmp = path;
  tmp += fmt::format(".{}.tmp", ::getpid());
  const auto fail = [&](const char* what, int err, bool remove_tmp) {
    if (remove_tmp) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
    }
    throw WriteError(
        fmt::format("cannot write {}: {} ({})", path.string(), std::strerror(err), what));
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail("creating the temporary file", errno, false);
  const char* p = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ::ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail("writing", err, true);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    fail("flushing", err, true);
  }
  if (::close(fd) != 0) fail("closing", errno, true);
  if (::rename(tmp.c_str(), path.c_str()) != 0) fail("renaming the temporary file", errno, true);
}

} // namespace demfem::scene
