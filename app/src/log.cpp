#include "log.hpp"

#include <fstream>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "demfem/studies/error_study.hpp"

namespace fs = std::filesystem;

namespace demfem::app {

namespace {

// Lines logged before a run directory's log.txt opens: printed, and kept for the top of that
// log.txt (setup_run_log), so that log.txt has everything the run said.
class PendingLines final : public spdlog::sinks::base_sink<std::mutex> {
public:
  std::vector<std::string> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::exchange(lines_, {});
  }

protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t buf;
    formatter_->format(msg, buf);
    lines_.emplace_back(buf.data(), buf.size());
  }
  void flush_() override {}

private:
  std::vector<std::string> lines_;
};

std::shared_ptr<PendingLines>& pending_lines() {
  static std::shared_ptr<PendingLines> p;
  return p;
}

} // namespace

void log_before_run_dir() {
  if (studies::study_rank() != 0) return; // other MPI ranks: warnings only (main)
  pending_lines() = std::make_shared<PendingLines>();
  auto console = std::make_shared<spdlog::sinks::stdout_color_sink_mt>();
  auto logger =
      std::make_shared<spdlog::logger>("demfem", spdlog::sinks_init_list{console, pending_lines()});
  logger->set_level(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

void setup_run_log(const fs::path& dir, bool append) {
  fs::create_directories(dir);
  std::vector<std::string> earlier;
  if (pending_lines()) earlier = pending_lines()->take();
  pending_lines().reset();
  auto console = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
  if (studies::study_rank() != 0) {
    // another MPI rank of the same run: the first rank writes log.txt (a second file sink on it
    // truncated and interleaved it) and the console; this one reports warnings and errors only
    console->set_level(spdlog::level::warn);
    auto logger = std::make_shared<spdlog::logger>("demfem", console);
    logger->set_level(spdlog::level::warn);
    spdlog::set_default_logger(logger);
    return;
  }
  if (!earlier.empty()) { // what this run logged before its directory existed, first
    std::ofstream early(dir / "log.txt", append ? std::ios::app : std::ios::trunc);
    for (const auto& l : earlier) early << l;
    if (!early) throw std::runtime_error("cannot write " + (dir / "log.txt").string());
  }
  auto file = std::make_shared<spdlog::sinks::basic_file_sink_mt>((dir / "log.txt").string(),
                                                                  !append && earlier.empty());
  console->set_level(spdlog::level::info);
  auto logger = std::make_shared<spdlog::logger>("demfem", spdlog::sinks_init_list{console, file});
  logger->set_level(spdlog::level::debug);
  logger->flush_on(spdlog::level::info);
  spdlog::set_default_logger(logger);
}

} // namespace demfem::app
