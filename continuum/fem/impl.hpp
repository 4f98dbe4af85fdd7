// Internal header of the deal.II/PETSc plane-strain solver: the model (`Model::Impl`) is its
// shared pieces (Core: mesh, dofs, materials, constraints, loads, point states, nodal fields;
// core.hpp) and its two integrators, each with its own state: `im` (implicit.hpp: Newton, static
// load stepping, Newmark-β; every run's initial state) and `ex` (explicit.hpp: central
// differences). Only the solver's translation units include it (deal.II's flags, C++17).
#pragma once

#include "core.hpp"
#include "explicit.hpp"
#include "implicit.hpp"

namespace demfem::continuum::fem {

struct Model::Impl : Core {
  Implicit im{*this};
  Explicit ex{*this};

  // mesh_only: the mesh, dofs and materials, no constraints, matrices or state (what the
  // explicit stable step needs: fem::stable_time_step)
  explicit Impl(const Problem& p, bool mesh_only = false);

  // the constraints again after a region's DoF modes changed (structure seating): u and v keep
  // their values, M/K0 are reassembled, the dynamic and explicit initialisations start over
  void reconstrain();
  // contact forces at the nodes of a plane: the explicit run's, or before it the reactions of
  // the implicit stages' constraints (the K0 state) (contact.cpp)
  [[nodiscard]] std::vector<Explicit::Contact> contact_state(std::size_t plane) const;
};

} // namespace demfem::continuum::fem
