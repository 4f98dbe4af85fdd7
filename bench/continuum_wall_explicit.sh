#!/usr/bin/env bash
# Explicit continuum integrator on the retaining-wall scene (bench/RESULTS.md, "Continuum
# explicit integrator").
# Usage: bench/continuum_wall_explicit.sh VARIANT DURATION_S TIMEOUT_S REFINEMENT...
#   e.g. bench/continuum_wall_explicit.sh case-2 2.0 600 3 4
# For each refinement: cases/retaining_wall.toml with continuum.integrator = "explicit" (automatic
# step), `scene.duration` = DURATION_S (shaking from t = 1 s as in the scene), no .vtu output,
# run with `demfem run --solver continuum` under `timeout` and /usr/bin/time (peak memory).
# Prints dofs, the explicit step, wall seconds per simulated second and the peak resident set.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
variant=$1 duration=$2 limit=$3
shift 3
bin=${DEMFEM:-$root/build/app/demfem}
work=${BENCH_DIR:-/tmp/demfem-bench-wall-explicit}
mkdir -p "$work"
for r in "$@"; do
  scene=$work/wall_r$r.toml
  sed -e "s/^duration = 26.0 .*/duration = $duration/" -e "/^integrator = /d" \
      -e "s/^refinement = [0-9]*.*/refinement = $r\nintegrator = \"explicit\"/" \
      -e 's/^dt = 0.01$/dt = 0.0/' \
      -e 's/^interval = 0.5$/interval = 0.5\nvtk = false/' \
      "$root/cases/retaining_wall.toml" > "$scene"
  out=$work/${variant}_r$r
  rm -rf "$out"
  rc=0
  /usr/bin/time -f "peak RSS %M kB" -o "$out.time" timeout "$limit" "$bin" run "$scene" \
    --solver continuum --variant "$variant" --out "$out" > "$out.log" 2>&1 || rc=$?
  echo "== refinement $r, $variant, $duration s simulated: exit $rc, $(cat "$out.time" | tail -1)"
  grep -E "continuum run|explicit|setup|dynamic:" "$out/continuum/log.txt" 2>/dev/null || true
done
