#!/bin/bash
# race-lammps.sh -- demfem vs LAMMPS, back to back, on the identical 2D bed.
#
# Usage:  bench/race-lammps.sh [N ...]        default N list: 10000 100000
# Environment knobs:
#   STEPS   timed steps (default 2000; a multiple of 10)
#   CORES   core counts (default "1 2"): LAMMPS MPI ranks / demfem OpenMP threads
#   REPS    interleaved repeats per (N, cores) (default 3; N >= 1e6: 1)
#   BUSY    1: keep the other core busy (stress-ng --cpu 1) during every run (default 0)
#   IDLE    the probe's lockstep value from which a repeat counts as idle (default 1.9; see
#           scaling_idle below)
#   ADAPT   demfem's team with cores > 1: 1 adaptive (default, as `demfem run`), 0 the full team
#           always (bench_dem_race's 6th argument)
#   BASELINE 1: each repeat also runs demfem with the one-pass scalar pair loop (bench_dem_race's
#           kernel "scalar", the loop before the blocked kernel), printed as "demfem-scalar …", and
#           the summary adds its speed and the blocked/scalar ratio (default 0)
#   LAMMPS_BENCH  the shared LAMMPS bench dir (default ../shared/bench/lammps-bed2d, else
#                 /work/shared/bench/lammps-bed2d); its run.sh runs LAMMPS
#   RACE_BIN      demfem's runner (default build/bench/bench_dem_race, else build-dem/…)
#   WORK    scratch dir (default /tmp/demfem_race): generated scenes, logs
#
# The scene: LAMMPS reads tile_settled.data.gz and replicates it N/10000 times along x
# (bed2d.in MODE timed); demfem reads the same positions, converted once per N by
# bench/lammps_tile_scene.py into a scene with particles_file = bed_<N>.npy (see that script for
# the parameter mapping). Each repeat runs LAMMPS and demfem back to back (the order alternates
# between repeats), so drifting machine load hits both alike; the load average is logged. Both
# clocks start after the setup: LAMMPS's "Loop time" after its first neighbour list and forces,
# demfem's loop_s after its first neighbour build (Engine::prepare; at 10⁶ it includes the sort
# into cell order).
#
# The machine: before each repeat, bench/machine-probe.sh prints
#   machine cpuA=<s> cpuB=<s> together=<s>/<s> ceiling=<x>
# ceiling: the throughput of two 1-thread runs at once over one alone on the faster CPU. On these
# project VMs it moves between ≈ 2, ≈ 1.6–1.7 and ≈ 1.2 from minute to minute: no program scales
# beyond it, so the summary prints each program's 1 → 2 core speed-up beside it.
#
# Output: one line per run (run.sh's format, "lammps …" / "demfem …"), then per (N, cores)
#   summary N=<n> cores=<c> lammps=<min>/<median>/<max> demfem=<min>/<median>/<max> (particle-steps/s)
#   ratio N=<n> cores=<c> demfem/lammps=<ratio of the medians> paired=<median of the repeats' ratios>
#   physics N=<n> cores=<c> Z_lammps=<z> Z_demfem=<z> diff=<%> ok|FAIL   (|diff| <= ZTOL %, default 3)
# and per N with cores 1 and 2
#   scaling N=<n> demfem=<2-core median / 1-core median> lammps=<…> machine_ceiling=<median>
#   scaling_idle N=<n> demfem=<…> lammps=<…> idle_repeats=<k>/<reps>
# scaling_idle takes the medians over the idle repeats only: those whose probe before and probe
# after (one more probe closes the last repeat) both gave lockstep >= IDLE. A 2-thread step of
# 10⁴ disks (≈ 115 µs) waits for the slower vCPU twice; in a minute when the host pauses one vCPU
# now and then, its 2-thread runs lose 10–40 % that its 1-thread runs, on one vCPU, may not.
# and the exit status is 1 when a physics check failed.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
STEPS=${STEPS:-2000}
CORES=${CORES:-"1 2"}
WORK=${WORK:-/tmp/demfem_race}
BUSY=${BUSY:-0}
ZTOL=${ZTOL:-3}
IDLE=${IDLE:-1.9}
NLIST=${*:-"10000 100000"}
if [ -z "${LAMMPS_BENCH:-}" ]; then
  for d in "$ROOT/../shared/bench/lammps-bed2d" /work/shared/bench/lammps-bed2d; do
    [ -f "$d/run.sh" ] && LAMMPS_BENCH=$(cd "$d" && pwd) && break
  done
fi
[ -f "${LAMMPS_BENCH:-}/run.sh" ] || { echo "race-lammps: no LAMMPS bench (set LAMMPS_BENCH)" >&2; exit 2; }
if [ -z "${RACE_BIN:-}" ]; then
  for b in "$ROOT/build/bench/bench_dem_race" "$ROOT/build-dem/bench/bench_dem_race"; do
    [ -x "$b" ] && RACE_BIN=$b && break
  done
fi
[ -x "${RACE_BIN:-}" ] || { echo "race-lammps: build bench_dem_race first (cmake --build build --target bench_dem_race)" >&2; exit 2; }
command -v lmp >/dev/null || { echo "race-lammps: no 'lmp' (apt-get install lammps)" >&2; exit 2; }
mkdir -p "$WORK"
RES="$WORK/results.txt"
: >"$RES"
echo "# race-lammps: $(date -u +%FT%TZ) $(uname -n) nproc=$(nproc) steps=$STEPS busy=$BUSY"
echo "# demfem: $RACE_BIN ($(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?'))"
lver=$(lmp -h 2>/dev/null | head -5 | grep -m1 -o '[0-9]* [A-Z][a-z]* 20[0-9][0-9].*' || true)
echo "# lammps: $LAMMPS_BENCH/run.sh (lmp: ${lver:-unknown version})"

stress_pid=
cleanup() { [ -n "$stress_pid" ] && kill "$stress_pid" 2>/dev/null || true; }
trap cleanup EXIT
if [ "$BUSY" = 1 ]; then
  command -v stress-ng >/dev/null || { echo "race-lammps: BUSY=1 needs stress-ng" >&2; exit 2; }
  stress-ng --cpu 1 --timeout 0 >/dev/null 2>&1 &
  stress_pid=$!
  echo "# other core kept busy: stress-ng --cpu 1 (pid $stress_pid)"
fi

run_lammps() { # N cores
  STEPS=$STEPS CORES=$2 REPS=1 WORK="$WORK/lammps" "$LAMMPS_BENCH/run.sh" "$1"
}
run_demfem() { # N cores [kernel]
  OMP_PROC_BIND=${OMP_PROC_BIND:-false} "$RACE_BIN" "$WORK/race_$1.toml" "$STEPS" "$2" 10 0 \
    "${ADAPT:-1}" "${3:-simd}" 2>>"$WORK/demfem_stderr.log"
}
run_demfem-scalar() { # N cores: the one-pass scalar pair loop
  run_demfem "$1" "$2" scalar | sed 's/^demfem /demfem-scalar /'
}
load() { cut -d' ' -f1 /proc/loadavg; }

for N in $NLIST; do
  python3 "$ROOT/bench/lammps_tile_scene.py" "$LAMMPS_BENCH/tile_settled.data.gz" "$N" "$STEPS" \
    "$WORK" >/dev/null
  if [ -n "${REPS:-}" ]; then reps=$REPS; elif [ "$N" -le 100000 ]; then reps=3; else reps=1; fi
  for r in $(seq 1 "$((reps + 1))"); do
    m=$(RACE_BIN=$RACE_BIN WORK=$WORK LAMMPS_BENCH=$LAMMPS_BENCH "$ROOT/bench/machine-probe.sh")
    if [ -n "$m" ]; then
      echo "$m load=$(load)"
      echo "$m rep=$r N=$N" >>"$RES"
    fi
    [ "$r" -le "$reps" ] || break # the last probe closes the last repeat
    for c in $CORES; do
      if [ $((r % 2)) -eq 1 ]; then order="lammps demfem"; else order="demfem lammps"; fi
      [ "${BASELINE:-0}" = 1 ] && order="$order demfem-scalar"
      for prog in $order; do
        l0=$(load)
        line=$(run_$prog "$N" "$c")
        echo "$line load=$l0->$(load)"
        echo "$line rep=$r req=$N" >>"$RES"
      done
    done
  done
done

awk -v tol="$ZTOL" -v idle="$IDLE" '
  function median(a, n,   i, j, t) { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++)
      if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return n % 2 ? a[(n + 1) / 2] : 0.5 * (a[n / 2] + a[n / 2 + 1]) }
  $1 == "machine" { r = 0; for (i = 2; i <= NF; i++) { split($i, kv, "=")
      if (kv[1] == "rep") r = kv[2]; else if (kv[1] == "lockstep") ls = kv[2]
      else if (kv[1] == "ceiling") ceil_v[$NF, ++ceil_n[$NF]] = kv[2] }
    lock[$NF, r] = ls
    next }
  {
    prog = $1; n = ""; c = ""; ps = 0; z = 0; r = 0
    for (i = 2; i <= NF; i++) { split($i, kv, "=");
      if (kv[1] == "N") n = kv[2]; else if (kv[1] == "cores") c = kv[2]; else if (kv[1] == "rep") r = kv[2];
      else if (kv[1] == "particle_steps_per_s") ps = kv[2]; else if (kv[1] == "contacts_per_particle") z = kv[2] }
    key = n " " c; if (!(key in seen)) { seen[key] = 1; keys[++nk] = key }
    cnt[prog, key]++; v[prog, key, cnt[prog, key]] = ps; zs[prog, key] += z; rp[prog, key, cnt[prog, key]] = r
  }
  END {
    bad = 0
    for (k = 1; k <= nk; k++) {
      key = keys[k]; split(key, nc, " ")
      for (p = 1; p <= 2; p++) { prog = p == 1 ? "lammps" : "demfem"; m = cnt[prog, key]
        delete a; mn = 1e300; mx = 0
        for (i = 1; i <= m; i++) { a[i] = v[prog, key, i]; if (a[i] < mn) mn = a[i]; if (a[i] > mx) mx = a[i] }
        med[prog] = median(a, m); s[prog] = sprintf("%.3g/%.3g/%.3g", mn, med[prog], mx)
        zm[prog] = zs[prog, key] / m }
      printf "summary N=%s cores=%s runs=%d lammps=%s demfem=%s (min/median/max particle-steps/s)\n", nc[1], nc[2], cnt["demfem", key], s["lammps"], s["demfem"]
      # paired: the median of the per-repeat ratios (LAMMPS and demfem run back to back in a
      # repeat, so a slow phase of the machine hits both); the ratio of the medians may pair a
      # fast phase of one program with a slow phase of the other.
      m = cnt["demfem", key]; if (cnt["lammps", key] < m) m = cnt["lammps", key]; delete a
      for (i = 1; i <= m; i++) a[i] = v["demfem", key, i] / v["lammps", key, i]
      printf "ratio N=%s cores=%s demfem/lammps=%.2f paired=%.2f\n", nc[1], nc[2], med["demfem"] / med["lammps"], median(a, m)
      d = 100 * (zm["demfem"] - zm["lammps"]) / zm["lammps"]; ok = (d <= tol && d >= -tol)
      if (!ok) bad = 1
      if (cnt["demfem-scalar", key] > 0) { m = cnt["demfem-scalar", key]; delete a
        for (i = 1; i <= m; i++) a[i] = v["demfem-scalar", key, i]
        ms = median(a, m)
        printf "baseline N=%s cores=%s demfem_scalar_median=%.3g blocked/scalar=%.2f scalar/lammps=%.2f\n", nc[1], nc[2], ms, med["demfem"] / ms, ms / med["lammps"] }
      printf "physics N=%s cores=%s Z_lammps=%.3f Z_demfem=%.3f diff=%+.2f%% %s\n", nc[1], nc[2], zm["lammps"], zm["demfem"], d, ok ? "ok" : "FAIL"
      mdn[nc[1], nc[2], "lammps"] = med["lammps"]; mdn[nc[1], nc[2], "demfem"] = med["demfem"]
    }
    for (k = 1; k <= nk; k++) { split(keys[k], nc, " "); n = nc[1]
      if (nc[2] != 2 || !((n, 1, "demfem") in mdn) || done_n[n]++) continue
      cl = "n/a"; m = ceil_n["N=" n]; delete a
      if (m > 0) { for (i = 1; i <= m; i++) a[i] = ceil_v["N=" n, i]; cl = sprintf("%.2f", median(a, m)) }
      printf "scaling N=%s demfem=%.2f lammps=%.2f machine_ceiling=%s (2-core over 1-core medians; ceiling: two 1-thread runs at once over one alone)\n", n, mdn[n, 2, "demfem"] / mdn[n, 1, "demfem"], mdn[n, 2, "lammps"] / mdn[n, 1, "lammps"], cl
      # The same from the idle repeats only: the probes before and after the repeat both gave
      # lockstep >= idle (machine-probe.sh), so neither vCPU was paused or slowed at either end.
      nid = 0; for (r = 1; (("N=" n), r) in lock; r++) if ((("N=" n), r + 1) in lock && lock["N=" n, r] >= idle && lock["N=" n, r + 1] >= idle) { ok_rep[n, r] = 1; nid++ }
      nr = r - 1; if (nr > 0) nr--
      for (p = 1; p <= 2; p++) { prog = p == 1 ? "lammps" : "demfem"
        for (c = 1; c <= 2; c++) { key = n " " c; delete a; m = 0
          for (i = 1; i <= cnt[prog, key]; i++) if (ok_rep[n, rp[prog, key, i]]) a[++m] = v[prog, key, i]
          idm[prog, c] = m > 0 ? median(a, m) : 0 } }
      if (nid > 0 && idm["demfem", 1] > 0 && idm["lammps", 1] > 0)
        printf "scaling_idle N=%s demfem=%.2f lammps=%.2f idle_repeats=%d/%d (as above, from the repeats with lockstep >= %.2f in the probes before and after)\n", n, idm["demfem", 2] / idm["demfem", 1], idm["lammps", 2] / idm["lammps", 1], nid, nr, idle
      else printf "scaling_idle N=%s none of %d repeats had lockstep >= %.2f before and after\n", n, nr, idle }
    exit bad
  }' "$RES"
