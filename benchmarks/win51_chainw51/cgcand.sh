#!/bin/bash
# cgcand.sh TREE FILE K TAG: callgrind instructions of the candidate step alone (candidates_in_windows
# over K even windows; K 0: schedule._candidates, the one call), after a fresh analyse + plan_inputs
# with the strokes frozen (gc.freeze, as the pipeline does); ONLY=1: the chains' kind alone.
# Needs libcgmark.so: gcc -O1 -shared -fPIC -o libcgmark.so cgmark.c (CGMARK=its path).
# Output in ${OUT:-/tmp}/TAG.out.1 (its "totals:" line).
HERE=$(cd "$(dirname "$0")" && pwd)
TREE=$1; F=$2; K=$3; TAG=$4; O=${OUT:-/tmp}
cd "$TREE" && export PYTHONPATH="$TREE"
NOFREEZE=$NOFREEZE ONLY=$ONLY valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=$O/$TAG.out \
    /tmp/venv/bin/python "$HERE/cgcand.py" "$F" "$K" > $O/$TAG.log 2>&1
echo "$TAG $(grep -h '^totals:' $O/$TAG.out.1 | awk '{print $2}')"
