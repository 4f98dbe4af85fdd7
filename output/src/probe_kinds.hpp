// The probe classes, one per kind (each defined in its own probe_<kind>.cpp).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "demfem/output/probe.hpp"

namespace demfem::output::detail {

// energy.csv: the DEM's energy budget (always written where the solver keeps one; an energy
// [[probe]] gives it an interval of its own).
class EnergyProbe final : public Probe {
public:
  explicit EnergyProbe(double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;
};

// structures.csv: every structure's pose and soil reaction (always written when the scene has
// structures).
class StructuresProbe final : public Probe {
public:
  StructuresProbe(std::vector<std::string> names, bool load_histories);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;

private:
  std::vector<std::string> names_;
  bool load_histories_;
};

// walls.csv: the thrust and reaction of every recorded wall and wall-thrust probe target.
class WallsProbe final : public Probe {
public:
  WallsProbe(std::vector<std::string> targets, double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;

private:
  std::vector<std::string> targets_;
};

// pressure_<target>.csv: the normal soil pressure on a wall or structure per height bin.
class PressureProbe final : public Probe {
public:
  PressureProbe(std::string target, int bins, double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;

private:
  std::string target_;
  int bins_;
};

// surface.csv: the top of the soil per x bin.
class SurfaceProbe final : public Probe {
public:
  SurfaceProbe(int bins, double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;

private:
  int bins_;
};

// loci.csv: the positions of traced particles.
class LociProbe final : public Probe {
public:
  LociProbe(std::vector<std::uint32_t> ids, double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;
  [[nodiscard]] const std::vector<std::uint32_t>& ids() const { return ids_; }

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;

private:
  std::vector<std::uint32_t> ids_;
};

// coordination.csv: the mean number of particle contacts per particle.
class CoordinationProbe final : public Probe {
public:
  explicit CoordinationProbe(double interval);
  [[nodiscard]] std::vector<std::string> columns() const override;

protected:
  void fill(ProbeSource& source, std::vector<double>& values) override;
};

} // namespace demfem::output::detail
