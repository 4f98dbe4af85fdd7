// A folder demfem writes into (a run directory, a calibration, a study): `.demfem/` in it holds
// the manifest — the marker that demfem made the folder and the list of the top-level entries it
// wrote there, the only ones it ever deletes — and the lock that lets one command at a time write
// into it. Everything else in the folder is the user's and is never touched.
#pragma once

#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace demfem::app {

// `.demfem`, `.demfem/manifest.txt`, `.demfem/lock`.
extern const char* const kOwnDir;
[[nodiscard]] std::filesystem::path manifest_file(const std::filesystem::path& dir);
// True when `dir` holds demfem's manifest (the marker).
[[nodiscard]] bool has_marker(const std::filesystem::path& dir);

struct OwnRequest {
  const char* command = "run"; // for messages: "demfem <command>: …"
  // The top-level entries the command may write (added to the manifest by commit()); a name
  // ending in '*' stands for every entry it begins (e.g. ".ranks-*").
  std::vector<std::string> writes;
  // The folder must exist and be demfem's (--resume, --report-only): else refused, nothing
  // created.
  bool must_exist = false;
  const char* must_exist_why = "nothing to continue"; // e.g. "no run to resume"
};

// The lock and the manifest of one folder, held by one command (the lock is released when this
// is destroyed or released).
class Ownership {
public:
  Ownership() = default;
  ~Ownership();
  Ownership(Ownership&& o) noexcept;
  Ownership& operator=(Ownership&& o) noexcept;
  Ownership(const Ownership&) = delete;
  Ownership& operator=(const Ownership&) = delete;

  [[nodiscard]] bool held() const { return fd_ >= 0; }
  [[nodiscard]] const std::filesystem::path& dir() const { return dir_; }
  // The manifest as it will be written by commit() (the entries this command may write included).
  [[nodiscard]] const std::set<std::string>& manifest() const { return manifest_; }
  // True when the manifest lists `name` (an entry ending in '*' lists every name it begins).
  [[nodiscard]] bool lists(const std::string& name) const;
  // Writes the marker and the manifest (before any of the entries it lists is written) and marks
  // the folder taken (the other ranks of an MPI launch wait for that). Throws scene::WriteError
  // naming the file.
  void commit();
  // Deletes those of `names` that the manifest lists; never anything else. Throws
  // std::runtime_error naming the path that could not be removed.
  void remove(const std::vector<std::string>& names) const;
  void release();

private:
  friend int take_ownership(const std::filesystem::path&, const OwnRequest&, Ownership&);
  std::filesystem::path dir_;
  int fd_ = -1;
  std::set<std::string> manifest_;
};

// Takes `dir` for one command: creates it when it does not exist; refuses (exit 2, the message
// printed) a folder that is not empty and not demfem's, naming what is in it — `--force` does
// not change that — and a folder another demfem command holds (naming its PID). A folder counts
// as demfem's when it holds the marker, when everything in it is a folder holding the marker (a
// parent of variants' run directories), or when its parent's manifest lists it (a calibration
// folder a run made). An entry of `req.writes` that is in the folder but not in its manifest
// (and not a demfem folder) is refused too: demfem overwrites only what it wrote. Nothing is
// written into an existing folder until commit(). Under an MPI launcher ranks > 0 take nothing:
// they wait until the first rank has taken the folder (commit). Returns kOk, kBadInput or
// kRunFailed (cannot create the folder).
int take_ownership(const std::filesystem::path& dir, const OwnRequest& req, Ownership& own);

} // namespace demfem::app
