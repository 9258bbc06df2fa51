#!/bin/bash
# cgfin.sh TREE TAG cand FILE K | TREE TAG whole FILE: instructions inside FNS (cgfin.py);
# output ${OUT:-/tmp}/TAG.out.1 ("totals:" line), printed as "TAG N".
HERE=$(cd "$(dirname "$0")" && pwd)
TREE=$1; TAG=$2; shift 2; O=${OUT:-/tmp}
cd "$TREE" && export PYTHONPATH="$TREE"
valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=$O/$TAG.out \
    /tmp/venv/bin/python "$HERE/cgfin.py" "$@" > $O/$TAG.log 2>&1
echo "$TAG $(grep -h '^totals:' $O/$TAG.out.1 | awk '{print $2}')"
