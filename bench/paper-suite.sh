#!/bin/bash
# paper-suite.sh -- every variant of the four paper scenes, DEM, from an empty packing cache,
# on JOBS processes at once (the target: the paper suite in under 5 minutes on 2 cores).
#
# Usage:  bench/paper-suite.sh [WORK]     WORK: a new scratch directory (default: mktemp -d)
# Environment: DEMFEM (default build/app/demfem), JOBS (default 2), PROBE=0 to skip the machine
#   probes (bench/machine-probe.sh, which needs build/bench/bench_dem_race and the shared LAMMPS
#   bench data).
# Runs, in WORK (so the packings cache, runs/packings, starts empty):
#   demfem run cases/<scene>.toml --solver dem --all-variants --jobs $JOBS --out WORK/out/<scene>
# for retaining_wall, pile_penetration, foundation_rocking and slope_ontake, then Ontake's base
# scene. Prints per scene "scene <name> rc=<rc> <s> s", then
#   suite total=<s> s idle=<core-s> (<% of the cores' time>) failed=<count>
# and, before and after, the machine probe's line (what a second core gives at that moment: on
# this project's VMs it changes from minute to minute; bench/RESULTS.md, "What the second vCPU gives").
# Exit status: 1 when a run failed. Each scene's console is WORK/out/<scene>.log.
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
DEMFEM=${DEMFEM:-$ROOT/build/app/demfem}
JOBS=${JOBS:-2}
WORK=${1:-$(mktemp -d /tmp/demfem_suite.XXXXXX)}
[ -x "$DEMFEM" ] || { echo "paper-suite: no $DEMFEM (build it first)" >&2; exit 2; }
if [ -e "$WORK/runs" ] || [ -e "$WORK/out" ]; then
  echo "paper-suite: $WORK already holds a suite (runs/ or out/): give a new directory" >&2
  exit 2
fi
mkdir -p "$WORK/out" && cd "$WORK" || exit 2
now() { date +%s.%N; }
minus() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", a - b }'; }
idle() { awk '/^cpu / { print $5 / 100 }' /proc/stat; } # idle seconds of all CPUs (USER_HZ 100)
probe() { [ "${PROBE:-1}" = 1 ] && "$ROOT/bench/machine-probe.sh" 2>/dev/null | sed "s/^/$1 /"; }
echo "# paper-suite: $(date -u +%FT%TZ) $(uname -n) nproc=$(nproc) jobs=$JOBS"
echo "# demfem: $DEMFEM ($("$DEMFEM" --version 2>/dev/null | tr '\n' ' ')$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null))"
echo "# work: $WORK"
probe before
failed=0
t0=$(now)
i0=$(idle)
run() { # label, then the demfem arguments
  local label=$1 t rc
  shift
  t=$(now)
  "$DEMFEM" run "$@" >"out/$label.log" 2>&1
  rc=$?
  [ "$rc" = 0 ] || failed=$((failed + 1))
  echo "scene $label rc=$rc $(minus "$(now)" "$t") s"
}
for s in retaining_wall pile_penetration foundation_rocking slope_ontake; do
  run "$s" "$ROOT/cases/$s.toml" --solver dem --all-variants --jobs "$JOBS" --out "out/$s"
done
run slope_ontake_base "$ROOT/cases/slope_ontake.toml" --solver dem --out out/slope_ontake_base
total=$(minus "$(now)" "$t0")
idle_s=$(minus "$(idle)" "$i0")
awk -v t="$total" -v i="$idle_s" -v n="$(nproc)" -v f="$failed" \
  'BEGIN { printf "suite total=%.1f s idle=%.1f core-s (%.1f %% of the cores'"'"' time) failed=%d\n", t, i, 100 * i / (n * t), f }'
probe after
[ "$failed" = 0 ]
