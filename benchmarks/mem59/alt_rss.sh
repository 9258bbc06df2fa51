#!/bin/bash
# usage: alt_rss.sh ROUNDS FILE PROFILE WINDOWED TREE_A TREE_B ...  -> one line a run: tree KB (/usr/bin/time -f %M)
# The trees alternated round by round (their bytecode compiled first, as an install leaves it).
R=$1; F=$2; P=$3; W=$4; shift 4
PY=${PYTHON:-/tmp/venv/bin/python}
for t in "$@"; do $PY -m compileall -q $t/gcode_opt; done
O=$(mktemp -d)
for r in $(seq $R); do
  for t in "$@"; do
    kb=$(cd $t && GCODE_OPT_WINDOWED=$W PYTHONPATH=$t /usr/bin/time -f %M $PY -m gcode_opt process $F -o $O/out.gcode -q --profile $P 2>&1 >/dev/null | tail -1)
    echo "$t $kb"
  done
done
rm -rf $O
