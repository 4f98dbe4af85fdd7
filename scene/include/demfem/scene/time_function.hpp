// Time functions shared by both solvers: loads, shaking amplitudes, prescribed motions.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace demfem::scene {

// A scalar function of time f(t). Plain data; evaluate() has no allocation.
//   constant : f = value
//   ramp     : f = offset + rate·max(0, t − start)                  (load type A, paper §4)
//   sine     : f = amplitude·sin(2π·frequency·(t − start) + phase) for t ≥ start, else 0
//   t-sine   : f = amplitude·t·sin(omega·t)                           (paper eq. 5.1)
//   table    : piecewise-linear through (t_i, f_i), held constant outside
//   sum      : f = Σ terms (e.g. load type B = ramp + sine)
struct TimeFunction {
  enum class Kind { Constant, Ramp, Sine, TSine, Table, Sum };
  Kind kind = Kind::Constant;
  double value = 0.0;     // constant
  double rate = 0.0;      // ramp
  double offset = 0.0;    // ramp
  double start = 0.0;     // ramp, sine
  double amplitude = 0.0; // sine, t-sine
  double frequency = 0.0; // sine [Hz]
  double phase = 0.0;     // sine [rad]
  double omega = 0.0;     // t-sine [rad/s]
  double stop = 0.0;      // sine/ramp: no effect after stop when stop > start (0 = never stops)
  std::vector<std::pair<double, double>> table;
  std::vector<TimeFunction> terms;

  [[nodiscard]] double operator()(double t) const;
  [[nodiscard]] std::string describe() const;

  static TimeFunction constant(double v);
  static TimeFunction ramp(double rate, double offset = 0.0, double start = 0.0);
  static TimeFunction sine(double amplitude, double frequency, double phase = 0.0,
                           double start = 0.0);
  static TimeFunction t_sine(double amplitude, double omega);
  static TimeFunction piecewise(std::vector<std::pair<double, double>> points);
  static TimeFunction sum(std::vector<TimeFunction> terms);
};

} // namespace demfem::scene
