#!/usr/bin/env bash
# Continuum solver timing on the retaining-wall scene (bench/RESULTS.md, "Continuum solver").
# Usage: bench/continuum_wall.sh VARIANT SOLVER TIMEOUT_S REFINEMENT...
#   e.g. bench/continuum_wall.sh case-2 direct 900 3 4
# For each refinement: cases/retaining_wall.toml with a short window (2 steps at rest from the
# K0 state, shaking from t = 0.02 s, 8 steps of 0.01 s in all), the given linear solver, run with
# `demfem run --solver continuum` under `timeout`. Prints dofs and, per step, Newton and linear
# iterations, step cuts and wall seconds (from <out>/continuum/steps.csv).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
variant=$1 solver=$2 limit=$3
shift 3
bin=${DEMFEM:-$root/build/app/demfem}
work=${BENCH_DIR:-/tmp/demfem-bench-wall}
mkdir -p "$work"
for r in "$@"; do
  scene=$work/wall_r$r.toml
  sed -e 's/^duration = 26.0 .*/duration = 0.08/' \
      -e "s/^refinement = [0-9]*.*/refinement = $r/" \
      -e 's/^integrator = .*/integrator = "implicit"/' -e 's/^dt = 0.0 .*/dt = 0.01/' \
      -e "s/^linear_solver = \"direct\".*/linear_solver = \"$solver\"/" \
      -e 's/start = 1.0 }/start = 0.02 }/' "$root/cases/retaining_wall.toml" > "$scene"
  out=$work/${variant}_${solver}_r$r
  rm -rf "$out"
  start=$(date +%s%N)
  rc=0
  timeout "$limit" "$bin" run "$scene" --solver continuum --variant "$variant" --out "$out" \
    > "$out.log" 2>&1 || rc=$?
  end=$(date +%s%N)
  echo "== refinement $r, $variant, $solver: exit $rc, $(((end - start) / 1000000)) ms wall"
  head -1 "$out/continuum/log.txt" 2>/dev/null || true
  cat "$out/continuum/steps.csv" 2>/dev/null || true
done
