#include "ownership.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "command.hpp"
#include "demfem/compare/report.hpp"
#include "demfem/scene/write_file.hpp"
#include "demfem/studies/error_study.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

const char* const kOwnDir = ".demfem";

namespace {

constexpr std::string_view kManifestHeader =
    "# demfem: the entries demfem wrote into this folder, one per line. demfem deletes or "
    "overwrites only these; everything else here is yours and is never touched.\n";

// A manifest entry names one entry, or every entry that starts with it when it ends in '*'.
bool matches(const std::string& entry, const std::string& name) {
  if (!entry.empty() && entry.back() == '*')
    return name.compare(0, entry.size() - 1, entry, 0, entry.size() - 1) == 0;
  return entry == name;
}

fs::path lock_file(const fs::path& dir) {
  return dir / kOwnDir / "lock";
}

std::set<std::string> read_manifest(const fs::path& dir) {
  std::set<std::string> names;
  std::ifstream in(manifest_file(dir));
  for (std::string l; std::getline(in, l);)
    if (!l.empty() && l[0] != '#') names.insert(l);
  return names;
}

// The folder's entries (names), sorted.
std::vector<std::string> entries(const fs::path& dir) {
  std::vector<std::string> v;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) v.push_back(e.path().filename().string());
  std::sort(v.begin(), v.end());
  return v;
}

bool marked_folder(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec) && has_marker(p);
}

// "a, b, c (and 4 more)", folders with a trailing slash.
std::string list_entries(const fs::path& dir, const std::vector<std::string>& names) {
  std::vector<std::string> shown;
  for (std::size_t k = 0; k < names.size() && k < 6; ++k) {
    std::error_code ec;
    shown.push_back(names[k] + (fs::is_directory(dir / names[k], ec) ? "/" : ""));
  }
  std::string s = fmt::format("{}", fmt::join(shown, ", "));
  if (names.size() > shown.size()) s += fmt::format(" (and {} more)", names.size() - shown.size());
  return s;
}

// A run directory of a demfem from before the manifest: its own files, no manifest.
bool older_demfem_run(const fs::path& dir) {
  std::error_code ec;
  return fs::exists(dir / "scene.resolved.toml", ec) || fs::exists(dir / "run_dem.json", ec) ||
         fs::exists(dir / "run_continuum.json", ec) || fs::exists(dir / "calibration.json", ec) ||
         (fs::exists(dir / "log.txt", ec) &&
          (fs::is_directory(dir / "dem", ec) || fs::is_directory(dir / "continuum", ec)));
}

// The lock file's text: "<pid>\n" while its holder checks the folder, "<pid> ready\n" once it has
// taken it (Ownership::commit), "" after a clean release.
std::string lock_text(int fd) {
  char buf[64] = {};
  const ::ssize_t n = ::pread(fd, buf, sizeof buf - 1, 0);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
}

// The PID written into a held lock file, or "" when it cannot be read.
std::string holder_pid(int fd) {
  std::string s = lock_text(fd);
  s = s.substr(0, s.find_first_of(" \n"));
  if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) return {};
  return s;
}

// An MPI rank > 0: waits until another process (the first rank) holds the folder's lock and has
// taken the folder (checked it, cleared what it clears, written the manifest), so that nothing
// this rank writes precedes that. When the first rank refuses the folder it exits, and the
// launcher ends this rank.
int wait_for_first_rank(const fs::path& dir) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t0 < std::chrono::minutes(10)) {
    const int fd = ::open(lock_file(dir).c_str(), O_RDONLY | O_CLOEXEC);
    if (fd >= 0) {
      const bool held = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
      const bool ready = lock_text(fd).find(" ready") != std::string::npos;
      ::close(fd);
      if (held && ready) return kOk;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  fmt::print(stderr,
             "demfem: MPI rank {}: the first rank did not take the folder {} in 10 minutes\n",
             studies::study_rank(), dir.string());
  return kRunFailed;
}

} // namespace

fs::path manifest_file(const fs::path& dir) {
  return dir / kOwnDir / "manifest.txt";
}

bool has_marker(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(manifest_file(dir), ec);
}

Ownership::~Ownership() {
  release();
}

Ownership::Ownership(Ownership&& o) noexcept
    : dir_(std::move(o.dir_)), fd_(std::exchange(o.fd_, -1)), manifest_(std::move(o.manifest_)) {}

Ownership& Ownership::operator=(Ownership&& o) noexcept {
  if (this != &o) {
    release();
    dir_ = std::move(o.dir_);
    fd_ = std::exchange(o.fd_, -1);
    manifest_ = std::move(o.manifest_);
  }
  return *this;
}

void Ownership::release() {
  if (fd_ < 0) return;
  // the PID goes with the lock (a PID left in the file names a holder that died holding it)
  if (::ftruncate(fd_, 0) != 0) {
  }
  ::close(fd_); // releases the flock
  fd_ = -1;
}

void Ownership::commit() {
  if (fd_ < 0) return;
  std::string text(kManifestHeader);
  for (const auto& n : manifest_) text += n + "\n";
  scene::write_file_atomic(manifest_file(dir_), text);
  // "ready": the other ranks of an MPI launch wait for it (take_ownership)
  const std::string ready = fmt::format("{} ready\n", ::getpid());
  if (::ftruncate(fd_, 0) != 0 ||
      ::pwrite(fd_, ready.data(), ready.size(), 0) != static_cast<::ssize_t>(ready.size()))
    throw scene::WriteError(
        fmt::format("cannot write {}: {}", lock_file(dir_).string(), std::strerror(errno)));
}

bool Ownership::lists(const std::string& name) const {
  return std::any_of(manifest_.begin(), manifest_.end(),
                     [&](const std::string& e) { return matches(e, name); });
}

void Ownership::remove(const std::vector<std::string>& names) const {
  if (fd_ < 0) return;
  std::vector<std::string> gone;
  for (const auto& n : names) {
    if (n.empty() || n.back() != '*') {
      if (lists(n)) gone.push_back(n);
      continue;
    }
    for (const auto& e : entries(dir_))
      if (matches(n, e) && lists(e)) gone.push_back(e);
  }
  for (const auto& n : gone) {
    std::error_code ec;
    fs::remove_all(dir_ / n, ec);
    if (ec)
      throw std::runtime_error(
          fmt::format("cannot clear {}: {}", (dir_ / n).string(), ec.message()));
  }
}

int take_ownership(const fs::path& dir, const OwnRequest& req, Ownership& own) {
  own.release();
  own = Ownership{};
  own.dir_ = dir;
  // Under an MPI launcher every rank runs the command: the first takes the folder for all.
  if (studies::study_rank() != 0) return wait_for_first_rank(dir);
  const std::string q = compare::shell_quote(dir.string());
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    if (req.must_exist) {
      fmt::print(stderr, "demfem {}: no folder {}: {}. Nothing was run.\n", req.command,
                 dir.string(), req.must_exist_why);
      return kBadInput;
    }
    fs::create_directories(dir, ec);
    if (ec) {
      fmt::print(stderr, "demfem: cannot create the run directory {}: {}\n", dir.string(),
                 ec.message());
      return kRunFailed;
    }
  } else if (!fs::is_directory(dir, ec)) {
    fmt::print(stderr,
               "demfem {}: {} is a file, not a folder. Use another --out. Nothing was run.\n",
               req.command, dir.string());
    return kBadInput;
  }

  std::set<std::string> adopted; // entries that are demfem's without being listed
  const bool marked = has_marker(dir);
  if (!marked) {
    const auto names = entries(dir);
    const bool all_demfem = std::all_of(names.begin(), names.end(), [&](const std::string& n) {
      return n == kOwnDir || marked_folder(dir / n);
    });
    // a folder its parent's manifest lists (e.g. the calibration a run wrote): all of it is
    // demfem's
    const bool parent_lists = dir.has_parent_path() && dir.filename() != "." &&
                              dir.filename() != ".." && has_marker(dir.parent_path()) &&
                              read_manifest(dir.parent_path()).count(dir.filename().string());
    if (parent_lists) adopted.insert(names.begin(), names.end());
    if (req.must_exist && !parent_lists) {
      fmt::print(stderr,
                 "demfem {}: {} was not made by this demfem (it has no {}, the record of what "
                 "demfem wrote there): {}. {}Nothing was run.\n",
                 req.command, dir.string(), (fs::path(kOwnDir) / "manifest.txt").string(),
                 req.must_exist_why,
                 older_demfem_run(dir)
                     ? fmt::format("A run directory of an older demfem cannot be continued by "
                                   "this one: run again into a new folder (move this one away "
                                   "first: mv {0} {0}.old). ",
                                   q)
                     : std::string());
      return kBadInput;
    }
    if (!names.empty() && !all_demfem && !parent_lists) {
      if (older_demfem_run(dir))
        fmt::print(stderr,
                   "demfem {}: {} looks like a run directory of an older demfem (it holds {}, "
                   "but no {}, the record of what demfem wrote there), so demfem will not "
                   "delete or overwrite anything in it; --force does not change that. Move it "
                   "away (mv {} {}.old) or delete it yourself (rm -r {}), then run again. "
                   "Nothing was run.\n",
                   req.command, dir.string(), list_entries(dir, names),
                   (fs::path(kOwnDir) / "manifest.txt").string(), q, q, q);
      else
        fmt::print(stderr,
                   "demfem {}: {} is not empty and was not made by demfem (it has no {}): it "
                   "holds {}. demfem writes only into a new or empty folder or one it made, and "
                   "never deletes or overwrites files it did not write; --force does not change "
                   "that. Use another --out (a new folder), or move these files away. Nothing "
                   "was run.\n",
                   req.command, dir.string(), (fs::path(kOwnDir) / "manifest.txt").string(),
                   list_entries(dir, names));
      return kBadInput;
    }
  }

  // The lock: one command at a time. flock is released by the kernel when its holder exits, so
  // the lock of a process that died is taken over; the PID in the file names the holder.
  fs::create_directories(dir / kOwnDir, ec);
  if (ec) {
    fmt::print(stderr, "demfem: cannot write into the run directory {}: {}\n", dir.string(),
               ec.message());
    return kRunFailed;
  }
  const fs::path lf = lock_file(dir);
  const int fd = ::open(lf.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    fmt::print(stderr, "demfem: cannot open the lock {}: {}\n", lf.string(), std::strerror(errno));
    return kRunFailed;
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    std::string pid = holder_pid(fd);
    ::close(fd);
    if (err == EWOULDBLOCK) {
      fmt::print(stderr,
                 "demfem {}: {} is in use: another demfem command ({}) is writing into it now "
                 "(lock {}). Two commands in one folder would mix their results. Wait for it to "
                 "finish (or stop it), or use another --out. Nothing was run.\n",
                 req.command, dir.string(), pid.empty() ? "PID unknown" : "PID " + pid,
                 lf.string());
      return kBadInput;
    }
    fmt::print(stderr, "demfem: cannot lock {}: {}\n", lf.string(), std::strerror(err));
    return kRunFailed;
  }
  const std::string me = fmt::format("{}\n", ::getpid());
  if (::ftruncate(fd, 0) != 0 ||
      ::pwrite(fd, me.data(), me.size(), 0) != static_cast<::ssize_t>(me.size())) {
    const int err = errno;
    ::close(fd);
    fmt::print(stderr, "demfem: cannot write {}: {}\n", lf.string(), std::strerror(err));
    return kRunFailed;
  }
  own.fd_ = fd;

  // What the command will write: each entry that exists must be demfem's.
  own.manifest_ = marked ? read_manifest(dir) : std::set<std::string>{};
  own.manifest_.insert(adopted.begin(), adopted.end());
  std::vector<std::string> foreign;
  for (const auto& w : req.writes)
    for (const auto& n : entries(dir))
      if (matches(w, n) && !own.lists(n) && !marked_folder(dir / n)) foreign.push_back(n);
  if (!foreign.empty()) {
    fmt::print(stderr,
               "demfem {}: {} holds {} that demfem did not write (its manifest {} does not list "
               "{}), so demfem will not overwrite or delete {}. Move {} away, or use another "
               "--out. Nothing was run.\n",
               req.command, dir.string(), list_entries(dir, foreign), manifest_file(dir).string(),
               foreign.size() == 1 ? "it" : "them", foreign.size() == 1 ? "it" : "them",
               foreign.size() == 1 ? "it" : "them");
    own.release();
    return kBadInput;
  }
  own.manifest_.insert(req.writes.begin(), req.writes.end());
  return kOk;
}

} // namespace demfem::app
