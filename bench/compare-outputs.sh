#!/bin/bash
# compare-outputs.sh BASE_DIR NEW_DIR: the files of two capture-outputs.sh directories by sha256;
# prints each file that differs (DIFF), is only in BASE_DIR (MISSING) or only in NEW_DIR (EXTRA).
# Console captures, run times and log.txt are left out (they hold timings).
set -eu
list() { (cd "$1" && find . -type f ! -name '*.console' ! -name '*.time' ! -name 'log.txt' \
  ! -name 'console.txt' -print0 | sort -z | xargs -0 sha256sum | sort -k2); }
join -j 2 -a1 -a2 -e MISSING -o 0,1.1,2.1 <(list "$1") <(list "$2") |
  awk '$2!=$3 {print $1, ($2=="MISSING"?"EXTRA":($3=="MISSING"?"MISSING":"DIFF"))}'
