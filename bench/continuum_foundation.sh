#!/usr/bin/env bash
# Continuum foundation-rocking runs (bench/RESULTS.md, "Continuum: foundation rocking").
# Usage: bench/continuum_foundation.sh VARIANT REFINEMENT...   e.g. … 2-A-quick 1 2 3
#   FORMER=1: the former set-up instead of the scene's (implicit Newmark, dt = 0.05 s, uniform
#   coarse grid); the refinement is still the argument.
# Runs `demfem run cases/foundation_rocking.toml --solver continuum --refinement R` under
# /usr/bin/time (peak memory) and prints the mesh, the step, the wall times and the foundation's
# rotation amplitude (max |rotation| in structures.csv) and its seating settlement (log.txt).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
variant=$1
shift
bin=${DEMFEM:-$root/build/app/demfem}
work=${BENCH_DIR:-/tmp/demfem-bench-foundation}
mkdir -p "$work"
scene=$root/cases/foundation_rocking.toml
tag=scene
if [ "${FORMER:-0}" = 1 ]; then
  tag=former
  scene=$work/foundation_former.toml
  sed -e 's/^integrator = "explicit"/integrator = "implicit"/' -e 's/^dt = 0.0 .*/dt = 0.05/' \
      -e 's/^mesh_size_near = .*/mesh_size_near = 0.0/' "$root/cases/foundation_rocking.toml" > "$scene"
fi
for r in "$@"; do
  out=$work/${variant}_${tag}_r$r
  rm -rf "$out"
  rc=0
  /usr/bin/time -f "%e s wall, peak RSS %M kB" -o "$out.time" "$bin" run "$scene" \
    --solver continuum --variant "$variant" --refinement "$r" --out "$out" > "$out.log" 2>&1 || rc=$?
  echo "== $tag, refinement $r, $variant: exit $rc, $(tail -1 "$out.time")"
  grep -E "continuum run|^explicit|setup and K0|^dynamic:|^seated structure" \
    "$out/continuum/log.txt" 2>/dev/null || true
  python3 - "$out/continuum/structures.csv" <<'PY' || true
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))
i = rows[0].index("foundation.rotation [rad]")
rot = [float(r[i]) for r in rows[1:]]
print(f"   rotation amplitude max|θ| = {max(abs(x) for x in rot):.4e} rad, θ(end) = {rot[-1]:.4e} rad")
PY
done
