#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "hooks.hpp"

namespace demfem::continuum::run_detail {

void CheckedStream::open(const std::filesystem::path& p, bool append) {
  path_ = p;
  errno = 0;
  f_.open(p, append ? std::ios::app : std::ios::trunc);
  check("creating");
}

CheckedStream& CheckedStream::operator<<(std::ostream& (*manip)(std::ostream&)) {
  if (f_.is_open() && error_.empty()) {
    manip(f_);
    check("writing");
  }
  return *this;
}

void CheckedStream::close() {
  if (!f_.is_open()) return;
  flush();
  f_.close();
  check("closing");
}

void CheckedStream::check(const char* step) {
  if (f_ || !error_.empty()) return;
  const int err = errno;
  error_ = fmt::format("cannot write {}: {} ({})", path_.string(),
                       err != 0 ? std::strerror(err) : "the stream failed", step);
}

} // namespace demfem::continuum::run_detail
