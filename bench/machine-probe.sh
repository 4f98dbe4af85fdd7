#!/bin/bash
# machine-probe.sh -- how much two cores of this machine give right now.
#
# Usage:  bench/machine-probe.sh        prints one line:
#   machine cpuA=<s> cpuB=<s> together=<s>/<s> ceiling=<x> lockstep=<x>
# A 1-thread demfem run (bench_dem_race, the 10⁴-disk race bed, 1,000 steps, ≈ 0.2 s) pinned to
# each of the first two CPUs this process may use, alone, then on both at once. ceiling: the
# throughput of the two at once over one run alone on the faster CPU — what any program can gain
# from the second core at this moment. lockstep: 2 × (the faster alone) / (the slower of the two
# at once) — what a program can gain whose two threads (or ranks) wait for each other every step,
# each with half the work: it runs at the pace of the slower CPU. A vCPU that the host pauses now
# and then (30 % slower over the probe) leaves ceiling ≈ 1.7 but lockstep ≈ 1.5; an even share of
# the work between the two cannot gain back what the pauses cost (bench/RESULTS.md,
# "What a lock-stepped team can gain"). On this project's VMs the ceiling moves between ≈ 2 (independent
# cores), ≈ 1.6–1.7 (one vCPU 1.3–1.4 times slower than the other: its host sibling busy) and
# ≈ 1.2 (both vCPUs on one host core) from minute to minute (bench/RESULTS.md,
# "What the second vCPU gives"). Prints nothing with fewer than 2 CPUs.
# Environment: RACE_BIN (default build/bench/bench_dem_race), WORK (default /tmp/demfem_race: the
# generated scene), LAMMPS_BENCH (the shared bench dir with tile_settled.data.gz).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${WORK:-/tmp/demfem_race}
RACE_BIN=${RACE_BIN:-$ROOT/build/bench/bench_dem_race}
if [ -z "${LAMMPS_BENCH:-}" ]; then
  for d in "$ROOT/../shared/bench/lammps-bed2d" /work/shared/bench/lammps-bed2d; do
    [ -f "$d/tile_settled.data.gz" ] && LAMMPS_BENCH=$(cd "$d" && pwd) && break
  done
fi
[ -x "$RACE_BIN" ] || { echo "machine-probe: no $RACE_BIN (build bench_dem_race)" >&2; exit 2; }
read -r -a cpus <<<"$(python3 -c 'import os; print(" ".join(map(str, sorted(os.sched_getaffinity(0))[:2])))')"
[ "${#cpus[@]}" -ge 2 ] || exit 0
mkdir -p "$WORK"
sc="$WORK/race_10000.toml"
if [ ! -f "$sc" ]; then
  [ -f "${LAMMPS_BENCH:-}/tile_settled.data.gz" ] || { echo "machine-probe: no LAMMPS bench data (set LAMMPS_BENCH)" >&2; exit 2; }
  python3 "$ROOT/bench/lammps_tile_scene.py" "$LAMMPS_BENCH/tile_settled.data.gz" 10000 2000 "$WORK" >/dev/null
fi
one() { taskset -c "$1" "$RACE_BIN" "$sc" 1000 1 0 0 1 2>/dev/null | grep -o 'loop_s=[0-9.]*' | cut -d= -f2; }
a=$(one "${cpus[0]}")
b=$(one "${cpus[1]}")
one "${cpus[0]}" >"$WORK/probe0.$$" &
one "${cpus[1]}" >"$WORK/probe1.$$"
wait
x=$(cat "$WORK/probe0.$$")
y=$(cat "$WORK/probe1.$$")
rm -f "$WORK/probe0.$$" "$WORK/probe1.$$"
awk -v a="$a" -v b="$b" -v x="$x" -v y="$y" -v c0="${cpus[0]}" -v c1="${cpus[1]}" 'BEGIN {
  f = a < b ? a : b
  printf "machine cpu%s=%.3f cpu%s=%.3f together=%.3f/%.3f ceiling=%.2f lockstep=%.2f\n", c0, a, c1, b, x, y, (1 / x + 1 / y) * f, 2 * f / (x > y ? x : y) }'
