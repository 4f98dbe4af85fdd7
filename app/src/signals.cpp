#include "signals.hpp"

#include <csignal>
#include <signal.h>

#include "demfem/compare/report.hpp"

namespace demfem::app {

namespace {

std::atomic<bool> g_interrupt{false};
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_stop_signal(int sig) {
  g_signal = sig;
  g_interrupt.store(true);
  struct sigaction dfl {};
  dfl.sa_handler = SIG_DFL;
  sigemptyset(&dfl.sa_mask);
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &dfl, nullptr);
}

std::string& the_command_line() {
  static std::string c;
  return c;
}

} // namespace

void install_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &sa, nullptr);
  struct sigaction ign {};
  ign.sa_handler = SIG_IGN;
  sigemptyset(&ign.sa_mask);
  ::sigaction(SIGXFSZ, &ign, nullptr);
}

std::atomic<bool>& stop_requested() {
  return g_interrupt;
}

const char* stop_signal_name() {
  switch (g_signal) {
  case SIGINT:
    return "SIGINT";
  case SIGTERM:
    return "SIGTERM";
  case SIGHUP:
    return "SIGHUP";
  default:
    return "a stop signal";
  }
}

Stopped::Stopped() : std::runtime_error(std::string("stopped by ") + stop_signal_name()) {}

scene::ProgressFn stoppable(scene::ProgressFn progress) {
  return [progress = std::move(progress)](const scene::Progress& p) {
    if (g_interrupt.load()) throw Stopped();
    if (progress) progress(p);
  };
}

void set_command_line(int argc, char** argv) {
  std::string c = "demfem";
  for (int i = 1; i < argc; ++i) {
    c += ' ';
    c += compare::shell_quote(argv[i]);
  }
  the_command_line() = c;
}

const std::string& command_line() {
  return the_command_line();
}

} // namespace demfem::app
