#include "demfem/scene/time_function.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

namespace demfem::scene {

namespace {
bool stopped(const TimeFunction& f, double t) {
  return f.stop > f.start && t > f.stop;
}
} // namespace

double TimeFunction::operator()(double t) const {
  switch (kind) {
  case Kind::Constant:
    return value;
  case Kind::Ramp: {
    // f = offset + rate·(t − start)⁺, frozen after stop (load type A, paper §4)
    const double te = stopped(*this, t) ? stop : t;
    return offset + rate * std::max(0.0, te - start);
  }
  case Kind::Sine:
    // f = A sin(2πf(t − t0) + φ)  (shaking, paper §6: m·A·sin 2πft)
    if (t < start || stopped(*this, t)) return 0.0;
    return amplitude * std::sin(2.0 * std::numbers::pi * frequency * (t - start) + phase);
  case Kind::TSine:
    // F = A·t·sin(ωt)  (paper eq. 5.1)
    return amplitude * t * std::sin(omega * t);
  case Kind::Table: {
    if (table.empty()) return 0.0;
    if (t <= table.front().first) return table.front().second;
    if (t >= table.back().first) return table.back().second;
    auto it = std::upper_bound(table.begin(), table.end(), t,
                               [](double v, const auto& p) { return v < p.first; });
    const auto& [t1, f1] = *it;
    const auto& [t0, f0] = *(it - 1);
    return f0 + (f1 - f0) * (t - t0) / (t1 - t0); // linear interpolation
  }
  case Kind::Sum: {
    double s = 0.0;
    for (const auto& term : terms) s += term(t);
    return s;
  }
  }
  return 0.0;
}

std::string TimeFunction::describe() const {
  switch (kind) {
  case Kind::Constant:
    return fmt::format("{}", value);
  case Kind::Ramp:
    return fmt::format("{} + {}·(t − {})⁺", offset, rate, start);
  case Kind::Sine:
    return fmt::format("{}·sin(2π·{}·(t − {}) + {})", amplitude, frequency, start, phase);
  case Kind::TSine:
    return fmt::format("{}·t·sin({}·t)", amplitude, omega);
  case Kind::Table:
    return fmt::format("table of {} points", table.size());
  case Kind::Sum: {
    std::string s;
    for (const auto& term : terms) {
      if (!s.empty()) s += " + ";
      s += term.describe();
    }
    return s;
  }
  }
  return "?";
}

TimeFunction TimeFunction::constant(double v) {
  TimeFunction f;
  f.kind = Kind::Constant;
  f.value = v;
  return f;
}
TimeFunction TimeFunction::ramp(double rate, double offset, double start) {
  TimeFunction f;
  f.kind = Kind::Ramp;
  f.rate = rate;
  f.offset = offset;
  f.start = start;
  return f;
}
TimeFunction TimeFunction::sine(double amplitude, double frequency, double phase, double start) {
  TimeFunction f;
  f.kind = Kind::Sine;
  f.amplitude = amplitude;
  f.frequency = frequency;
  f.phase = phase;
  f.start = start;
  return f;
}
TimeFunction TimeFunction::t_sine(double amplitude, double omega) {
  TimeFunction f;
  f.kind = Kind::TSine;
  f.amplitude = amplitude;
  f.omega = omega;
  return f;
}
TimeFunction TimeFunction::piecewise(std::vector<std::pair<double, double>> points) {
  TimeFunction f;
  f.kind = Kind::Table;
  f.table = std::move(points);
  return f;
}
TimeFunction TimeFunction::sum(std::vector<TimeFunction> terms) {
  TimeFunction f;
  f.kind = Kind::Sum;
  f.terms = std::move(terms);
  return f;
}

} // namespace demfem::scene
