// Helpers shared by the end-to-end tests of the `demfem` binary (tests/app): run it through the
// shell or as a child process (to signal it or limit its file size), read files back.
#pragma once

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include "../scratch.hpp"

namespace demfem::test {

namespace fs = std::filesystem;

struct Result {
  int code = -1;   // exit status; -1 when the process did not exit normally
  std::string out; // stdout and stderr together
};

inline std::string slurp(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Runs a shell command line, capturing stdout and stderr together.
inline Result run_raw(const std::string& command) {
  const fs::path log = scratch("cli.log");
  const std::string cmd = command + " > " + log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  Result r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(log);
  fs::remove(log);
  return r;
}

// `demfem ARGS` through the shell.
inline Result run(const std::string& args) {
  return run_raw(std::string(DEMFEM_BINARY) + " " + args);
}

inline fs::path write_temp(const std::string& name, const std::string& text) {
  const fs::path p = scratch(name); // this test's own directory (tests/scratch.hpp)
  std::ofstream(p) << text;
  return p;
}

// A case file's text with `key = …` lines replaced (first occurrence after "\n"), e.g.
// with_values(text, {{"duration", "8.0"}}).
inline std::string with_values(std::string text,
                               const std::vector<std::pair<std::string, std::string>>& kv) {
  for (const auto& [k, v] : kv) {
    const auto pos = text.find("\n" + k + " = ");
    if (pos == std::string::npos) continue;
    text.replace(pos, text.find('\n', pos + 1) - pos, "\n" + k + " = " + v);
  }
  return text;
}

// `demfem ARGS…` as a child process (no shell) with stdout and stderr to `log`. A positive
// `file_size_limit` sets RLIMIT_FSIZE (bytes) in the child before exec; SIGXFSZ is ignored there
// (unless `ignore_sigxfsz` is false: then demfem's own handling is what is tested), so an
// over-long write fails with EFBIG instead of killing the process.
class Child {
public:
  Child(const std::vector<std::string>& args, const fs::path& log, long long file_size_limit = 0,
        bool ignore_sigxfsz = true)
      : log_(log) {
    std::vector<std::string> argv{DEMFEM_BINARY};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    pid_ = ::fork();
    if (pid_ == 0) {
      std::FILE* f = std::fopen(log.c_str(), "w");
      if (f) {
        ::dup2(::fileno(f), 1);
        ::dup2(::fileno(f), 2);
      }
      std::signal(SIGXFSZ, SIG_DFL);
      if (file_size_limit > 0) {
        if (ignore_sigxfsz) std::signal(SIGXFSZ, SIG_IGN);
        rlimit rl{static_cast<rlim_t>(file_size_limit), static_cast<rlim_t>(file_size_limit)};
        ::setrlimit(RLIMIT_FSIZE, &rl);
      }
      ::execv(cargv[0], cargv.data());
      ::_exit(127);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  ~Child() {
    if (pid_ > 0 && !waited_) {
      ::kill(pid_, SIGKILL);
      wait();
    }
  }
  [[nodiscard]] bool started() const { return pid_ > 0; }
  [[nodiscard]] pid_t pid() const { return pid_; }
  void signal(int sig) const { ::kill(pid_, sig); }
  // True while the child has not exited (reaps it when it has).
  bool running() {
    if (waited_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      finish(status);
      return false;
    }
    return true;
  }
  // Waits for the exit and returns the exit code and output (code −1 if killed by a signal).
  Result wait() {
    if (!waited_) {
      int status = 0;
      ::waitpid(pid_, &status, 0);
      finish(status);
    }
    return {code_, slurp(log_)};
  }

private:
  void finish(int status) {
    waited_ = true;
    code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  fs::path log_;
  pid_t pid_ = -1;
  bool waited_ = false;
  int code_ = -1;
};

// Every regular file under dir (recursively), relative path → bytes.
inline std::map<std::string, std::string> files_under(const fs::path& dir) {
  std::map<std::string, std::string> m;
  if (!fs::is_directory(dir)) return m;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) m[fs::relative(e.path(), dir).string()] = slurp(e.path());
  return m;
}

} // namespace demfem::test
