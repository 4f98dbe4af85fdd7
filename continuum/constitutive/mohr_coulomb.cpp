#include "mohr_coulomb.hpp"

#include "demfem/scene/params.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace demfem::continuum::constitutive {
namespace mohr_coulomb {
namespace {

struct Spectral {
  double xa = 0.0, xb = 0.0; // in-plane eigenvalues (xa ≥ xb)
  Voigt Ea{}, Eb{};          // eigenprojections as tensor components (xx, zz, xz)
};

// Eigen-decomposition of a symmetric 2×2 tensor given by tensor components (xx, zz, xz).
Spectral spectral(double xx, double zz, double xz) {
  Spectral s;
  const double m = 0.5 * (xx + zz);
  const double d = 0.5 * (xx - zz);
  const double r = std::hypot(d, xz);
  s.xa = m + r;
  s.xb = m - r;
  const double theta = 0.5 * std::atan2(xz, d); // eigenvector angle of xa
  const double c = std::cos(theta), n = std::sin(theta);
  s.Ea = {c * c, n * n, c * n};
  s.Eb = {n * n, c * c, -c * n};
  return s;
}

// Solve A x = b (n ≤ 3) by Gaussian elimination with partial pivoting; false when singular.
bool solve(int n, double A[3][3], double b[3], double x[3]) {
  double scale = 0.0;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) scale = std::max(scale, std::abs(A[i][j]));
  if (scale == 0.0) return false;
  for (int k = 0; k < n; ++k) {
    int piv = k;
    for (int i = k + 1; i < n; ++i)
      if (std::abs(A[i][k]) > std::abs(A[piv][k])) piv = i;
    if (std::abs(A[piv][k]) < 1e-12 * scale) return false;
    if (piv != k) {
      for (int j = 0; j < n; ++j) std::swap(A[k][j], A[piv][j]);
      std::swap(b[k], b[piv]);
    }
    for (int i = k + 1; i < n; ++i) {
      const double f = A[i][k] / A[k][k];
      for (int j = k; j < n; ++j) A[i][j] -= f * A[k][j];
      b[i] -= f * b[k];
    }
  }
  for (int i = n - 1; i >= 0; --i) {
    double s = b[i];
    for (int j = i + 1; j < n; ++j) s -= A[i][j] * x[j];
    x[i] = s / A[i][i];
  }
  return true;
}

// Inverse of a ≤3×3 matrix via column solves.
bool invert(int n, const double A[3][3], double Ainv[3][3]) {
  for (int c = 0; c < n; ++c) {
    double M[3][3], b[3] = {0, 0, 0}, x[3] = {0, 0, 0};
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) M[i][j] = A[i][j];
    b[c] = 1.0;
    if (!solve(n, M, b, x)) return false;
    for (int i = 0; i < n; ++i) Ainv[i][c] = x[i];
  }
  return true;
}

struct Surface {
  Voigt a{}; // yield gradient in sorted principal space: Φ = a·σ − r
  double r = 0.0;
  Voigt n{}; // flow direction (plastic potential gradient)
};

} // namespace

double yield(const Strength& strength, double s1, double s3) {
  const double sp = std::sin(strength.friction);
  // Φ = (σ1 − σ3) + (σ1 + σ3) sin φ − 2c cos φ (de Souza Neto et al. 2008, eq. 6.118)
  return (s1 - s3) + (s1 + s3) * sp - 2.0 * strength.cohesion * std::cos(strength.friction);
}

Result integrate(const Hooke& e, const Strength& strength, const ElasticStrain& trial,
                 bool plastic_predictor) {
  Result res;
  const double lam = e.lame(), G = e.shear_modulus();
  const Spectral sp = spectral(trial.in_plane[0], trial.in_plane[1], 0.5 * trial.in_plane[2]);
  const double x[3] = {sp.xa, sp.xb, trial.out_of_plane}; // principal elastic trial strains
  const double trx = x[0] + x[1] + x[2];
  double st[3];
  for (int i = 0; i < 3; ++i) st[i] = lam * trx + 2 * G * x[i]; // principal trial stresses

  // sort: perm[k] = original index of the k-th largest principal stress
  int perm[3] = {0, 1, 2};
  std::sort(perm, perm + 3, [&](int i, int j) { return st[i] > st[j]; });
  double s[3] = {st[perm[0]], st[perm[1]], st[perm[2]]};

  double dsdst[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}; // d σ_sorted / d σtrial_sorted
  { // the return to the yield surfaces (Mohr–Coulomb planes, tension cut-off)
    const double sphi = std::sin(strength.friction), cphi = std::cos(strength.friction);
    const double spsi = std::sin(strength.dilation);
    const bool tension = strength.tension_cutoff >= 0.0;
    // Surfaces in sorted principal space (tension positive):
    // 0: MC(1,3), 1: MC(2,3), 2: MC(1,2); 3..5: σ_k ≤ t (Rankine tension cut-off).
    Surface surf[6];
    surf[0] = {
        {1 + sphi, 0, -(1 - sphi)}, 2 * strength.cohesion * cphi, {1 + spsi, 0, -(1 - spsi)}};
    surf[1] = {
        {0, 1 + sphi, -(1 - sphi)}, 2 * strength.cohesion * cphi, {0, 1 + spsi, -(1 - spsi)}};
    surf[2] = {
        {1 + sphi, -(1 - sphi), 0}, 2 * strength.cohesion * cphi, {1 + spsi, -(1 - spsi), 0}};
    for (int k = 0; k < 3; ++k) {
      surf[3 + k].a = {0, 0, 0};
      surf[3 + k].a[static_cast<std::size_t>(k)] = 1.0;
      surf[3 + k].n = surf[3 + k].a;
      surf[3 + k].r = strength.tension_cutoff;
    }
    const int nsurf = tension ? 6 : 3;
    auto phi = [&](int k, const double v[3]) {
      const Surface& f = surf[k];
      return f.a[0] * v[0] + f.a[1] * v[1] + f.a[2] * v[2] - f.r;
    };
    const double scale = std::abs(s[0]) + std::abs(s[2]) + strength.cohesion + 1e-300 +
                         (tension ? std::abs(strength.tension_cutoff) : 0.0);
    const double tol = 1e-10 * scale;
    bool yielded = phi(0, s) > tol;
    if (tension && phi(3, s) > tol) yielded = true;
    if (!yielded && plastic_predictor && phi(0, s) > -1e-6 * scale) {
      // on the main plane: dσ/dσtr = I − DN aᵀ/(a·DN) (continuum elastoplastic tangent, Δγ = 0)
      const Surface& f = surf[0];
      const double trn = f.n[0] + f.n[1] + f.n[2];
      double DN[3];
      for (int i = 0; i < 3; ++i) DN[i] = lam * trn + 2 * G * f.n[static_cast<std::size_t>(i)];
      const double aDN = f.a[0] * DN[0] + f.a[1] * DN[1] + f.a[2] * DN[2];
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          dsdst[i][j] = ((i == j) ? 1.0 : 0.0) - DN[i] * f.a[static_cast<std::size_t>(j)] / aDN;
    }
    if (yielded) {
      // D N_k in principal space: D = λ 1⊗1 + 2G I
      double DN[6][3];
      for (int k = 0; k < nsurf; ++k) {
        const double trn = surf[k].n[0] + surf[k].n[1] + surf[k].n[2];
        for (int i = 0; i < 3; ++i)
          DN[k][i] = lam * trn + 2 * G * surf[k].n[static_cast<std::size_t>(i)];
      }
      struct Candidate {
        int n;
        int set[3];
        Return region;
      };
      static const Candidate candidates[] = {
          {1, {0, 0, 0}, Return::MainPlane},   {1, {3, 0, 0}, Return::Tension},
          {2, {0, 1, 0}, Return::EdgeLeft},    {2, {0, 2, 0}, Return::EdgeRight},
          {2, {0, 3, 0}, Return::TensionMain}, {2, {3, 4, 0}, Return::Tension},
          {3, {0, 3, 4}, Return::TensionEdge}, {3, {0, 1, 3}, Return::TensionEdge},
          {3, {0, 2, 3}, Return::TensionEdge}, {3, {0, 1, 2}, Return::Apex},
          {3, {3, 4, 5}, Return::TensionApex}};
      bool found = false;
      double best_violation = std::numeric_limits<double>::infinity();
      double best_s[3] = {0, 0, 0}, best_d[3][3] = {};
      Return best_region = Return::MainPlane;
      double best_dg = 0.0;
      for (const Candidate& cand : candidates) {
        if (cand.region == Return::Apex) continue; // handled below
        bool usable = true;
        for (int i = 0; i < cand.n; ++i)
          if (cand.set[i] >= nsurf) usable = false;
        if (!usable) continue;
        const int n = cand.n;
        // Linear closest-point system: Φ_i(σtr − Σ_k Δγ_k D N_k) = 0 for i in the active set
        double A[3][3] = {}, b[3] = {}, dg[3] = {};
        for (int i = 0; i < n; ++i) {
          b[i] = phi(cand.set[i], s);
          for (int k = 0; k < n; ++k) {
            const Surface& fi = surf[cand.set[i]];
            A[i][k] = fi.a[0] * DN[cand.set[k]][0] + fi.a[1] * DN[cand.set[k]][1] +
                      fi.a[2] * DN[cand.set[k]][2];
          }
        }
        double Acopy[3][3];
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) Acopy[i][k] = A[i][k];
        if (!solve(n, Acopy, b, dg)) continue;
        double snew[3] = {s[0], s[1], s[2]};
        double dgsum = 0.0;
        for (int k = 0; k < n; ++k) {
          dgsum += dg[k];
          for (int i = 0; i < 3; ++i) snew[i] -= dg[k] * DN[cand.set[k]][i];
        }
        // violation: negative multipliers, yield surfaces exceeded, ordering lost
        double viol = 0.0;
        for (int k = 0; k < n; ++k) viol = std::max(viol, -dg[k] * A[k][k]);
        for (int k = 0; k < nsurf; ++k) viol = std::max(viol, phi(k, snew));
        viol = std::max(viol, snew[1] - snew[0]);
        viol = std::max(viol, snew[2] - snew[1]);
        // tangent: dσ/dσtr = I − Σ_k DN_k (A⁻¹)_{ki} a_iᵀ (linearised consistency)
        double Ainv[3][3] = {};
        if (!invert(n, A, Ainv)) continue;
        double d[3][3];
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) {
            double v = (i == j) ? 1.0 : 0.0;
            for (int k = 0; k < n; ++k)
              for (int l = 0; l < n; ++l)
                v -= DN[cand.set[k]][i] * Ainv[k][l] *
                     surf[cand.set[l]].a[static_cast<std::size_t>(j)];
            d[i][j] = v;
          }
        if (viol < best_violation) {
          best_violation = viol;
          for (int i = 0; i < 3; ++i) {
            best_s[i] = snew[i];
            for (int j = 0; j < 3; ++j) best_d[i][j] = d[i][j];
          }
          best_region = cand.region;
          best_dg = dgsum;
        }
        if (viol <= tol) {
          found = true;
          break;
        }
      }
      if (!found && sphi > 1e-12) {
        // Apex return (perfect plasticity): σ = c cot φ · 1, dσ/dε = 0 (de Souza Neto et al.
        // 2008, Box 8.5); with ψ ≠ φ no non-negative combination of plane flows reaches it.
        const double apex = strength.cohesion * cphi / sphi;
        for (int i = 0; i < 3; ++i) {
          best_s[i] = apex;
          for (int j = 0; j < 3; ++j) best_d[i][j] = 0.0;
        }
        best_region = Return::Apex;
        const double ptr = (s[0] + s[1] + s[2]) / 3.0;
        best_dg = (ptr - apex) / (3.0 * (lam + 2.0 * G / 3.0)); // Δεv^p / 3 as a size measure
        found = true;
      }
      // when no candidate is admissible (φ = 0 without cut-off cannot get here) the
      // least-violating one is used
      for (int i = 0; i < 3; ++i) {
        s[i] = best_s[i];
        for (int j = 0; j < 3; ++j) dsdst[i][j] = best_d[i][j];
      }
      res.region = best_region;
      res.plastic_multiplier = best_dg;
    }
  }

  // principal stresses and principal tangent dy_i/dx_j in the original (a, b, yy) order
  double y[3], dydx[3][3];
  for (int k = 0; k < 3; ++k) y[perm[k]] = s[k];
  for (int k = 0; k < 3; ++k)
    for (int l = 0; l < 3; ++l) {
      // (dσ/dσtr)·De with De = λ 1⊗1 + 2G I in principal space
      double v = 0.0;
      for (int m = 0; m < 3; ++m) v += dsdst[k][m] * (lam + ((m == l) ? 2 * G : 0.0));
      dydx[perm[k]][perm[l]] = v;
    }

  // stress tensor: σ = Σ y_i E_i (in-plane) and σyy = y_c
  for (int c = 0; c < 3; ++c) res.stress[c] = y[0] * sp.Ea[c] + y[1] * sp.Eb[c];
  res.stress_yy = y[2];
  // elastic strain after the return: εe = D⁻¹σ in principal space
  const double try_ = y[0] + y[1] + y[2];
  double xe[3];
  for (int i = 0; i < 3; ++i) xe[i] = ((1 + e.poisson) * y[i] - e.poisson * try_) / e.young;
  res.elastic.in_plane = {xe[0] * sp.Ea[0] + xe[1] * sp.Eb[0], xe[0] * sp.Ea[1] + xe[1] * sp.Eb[1],
                          2.0 * (xe[0] * sp.Ea[2] + xe[1] * sp.Eb[2])};
  res.elastic.out_of_plane = xe[2];

  // Consistent tangent of an isotropic tensor function in 2D, de Souza Neto et al. (2008)
  // eq. (A.46): dσ/dε = Σ_ij ∂y_i/∂x_j E_i⊗E_j + (y_a − y_b)/(x_a − x_b)(I_s − E_a⊗E_a − E_b⊗E_b)
  const double dx = x[0] - x[1];
  const double coef = (std::abs(dx) > 1e-12 * (std::abs(x[0]) + std::abs(x[1]) + 1e-300))
                          ? (y[0] - y[1]) / dx
                          : dydx[0][0] - dydx[0][1];
  const Voigt* E[2] = {&sp.Ea, &sp.Eb};
  const double Is[3] = {1.0, 1.0, 0.5};
  for (int I = 0; I < 3; ++I)
    for (int J = 0; J < 3; ++J) {
      double v = 0.0;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) v += dydx[i][j] * (*E[i])[I] * (*E[j])[J];
      const double proj = (*E[0])[I] * (*E[0])[J] + (*E[1])[I] * (*E[1])[J];
      v += coef * (((I == J) ? Is[I] : 0.0) - proj);
      res.tangent[I][J] = v;
    }
  return res;
}

} // namespace mohr_coulomb

MohrCoulomb::MohrCoulomb(const Elastic::Parameters& elastic, const Parameters& p)
    : el(elastic.elasticity()) {
  strength.friction = p.friction_angle;
  strength.cohesion = p.cohesion;
  strength.dilation = p.dilation_angle;
  strength.tension_cutoff = p.tension_cutoff > 0.0 ? p.tension_cutoff : -1.0;
  strength_cut = strength;
  strength_cut.dilation = 0.0;
  if (!std::isnan(p.dilation_cutoff)) dilation_cutoff = p.dilation_cutoff;
}

void MohrCoulomb::Parameters::fields(scene::ParamVisitor& v) {
  using scene::Field;
  v.number({"friction_angle", "φ", "°", "Mohr–Coulomb friction angle", scene::Scale::none,
            Field::Value::degrees},
           friction_angle, scene::in_range(0.0, 89.0));
  v.number({"cohesion", "c", "Pa", "Mohr–Coulomb cohesion"}, cohesion, scene::non_negative());
  v.number({"dilation_angle", "ψ", "°", "dilatancy angle of the plastic flow (non-associated)",
            scene::Scale::none, Field::Value::degrees},
           dilation_angle, scene::in_range(0.0, 89.0));
  v.number({"tension_cutoff", "t", "Pa",
            "largest principal stress (tension positive) the soil carries; 0: none"},
           tension_cutoff, scene::non_negative());
  v.number({"dilation_cutoff", "ε_v,cut", "",
            "plastic volumetric strain (dilation positive) after which a point flows with ψ = 0 "
            "(PLAXIS's dilatancy cut-off); unset: none",
            scene::Scale::none, Field::Value::optional},
           dilation_cutoff, scene::in_range(0.0, 1.0));
}

void MohrCoulomb::Parameters::check(scene::ParamCheck& c) const {
  if (dilation_angle > friction_angle)
    c.error("dilation_angle", "dilation angle must not exceed the friction angle");
}

scene::ModelEntry MohrCoulomb::entry() {
  return {keyword,
          "elastic–perfectly plastic Mohr–Coulomb, non-associated flow, tension and dilatancy "
          "cut-offs",
          {scene::ParamBlock(Elastic::Parameters{}), scene::ParamBlock(Parameters{})}};
}

MohrCoulomb MohrCoulomb::from(const scene::ModelChoice& choice) {
  return MohrCoulomb(choice.get<Elastic::Parameters>(), choice.get<Parameters>());
}

} // namespace demfem::continuum::constitutive
