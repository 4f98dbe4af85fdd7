#!/bin/bash
# capture-outputs.sh BIN_DIR OUT_DIR SRC_DIR: deterministic outputs of paper scenes for byte comparison.
# BIN_DIR holds app/demfem (+ its module); cases are read from SRC_DIR/cases.
set -u
bin=$1/app/demfem; out=$2; src=$3
mkdir -p "$out"; cd "$out" || exit 2
export DEMFEM_CONTINUUM_MODULE=$1/app/libdemfem-continuum.so
"$bin" --version > version.txt 2>&1
for f in "$src"/cases/*.toml "$src"/cases/verification/*.toml; do
  n=$(basename "$f" .toml); "$bin" check --resolved "$f" > "check_$n.toml" 2>&1; echo "check $n rc=$?"
done
run() { local name=$1; shift; /usr/bin/time -f "%e s" -o "$name.time" "$bin" "$@" --out "$out/$name" > "$name.console" 2>&1; echo "$name rc=$? $(cat $name.time)"; }
run wall_quick_cmp compare "$src/cases/retaining_wall.toml" --variant quick
run found_quick_cmp compare "$src/cases/foundation_rocking.toml" --variant 2-A-quick
run pile_c1 run "$src/cases/pile_penetration.toml" --variant case-1 --solver dem
run slope_mu02 run "$src/cases/slope_ontake.toml" --variant basal-mu-0.2 --solver dem
run wall_c4_dem run "$src/cases/retaining_wall.toml" --variant case-4 --solver dem
run head_on run "$src/cases/verification/head_on_collision.toml" --solver dem
run elastic_gas run "$src/cases/verification/elastic_gas.toml" --solver dem
run footing_cont run "$src/cases/verification/continuum_footing_load.toml" --solver continuum
