#!/bin/bash
# Instructions of the whole command (valgrind's callgrind; deterministic, unlike CPU time on a
# shared machine), the hash seed fixed:
#   bash benchmarks/callgrind_command.sh TREE FILE TAG [PROFILE]   -> "TAG Collected : N"
# The profile is in /tmp/cg/TAG.out (callgrind_annotate).  PYTHON: the interpreter (python3).
TREE=$(cd "$1" && pwd); F=$(realpath "$2"); TAG=$3; P=${4:-prusa-mk3s}
mkdir -p /tmp/cg
cd "$TREE" && PYTHONHASHSEED=1 PYTHONPATH=$TREE valgrind --tool=callgrind --callgrind-out-file=/tmp/cg/$TAG.out \
    ${PYTHON:-python3} -m gcode_opt process "$F" -o /tmp/cg/$TAG.gcode -q --profile "$P" > /tmp/cg/$TAG.log 2>&1
grep -o "Collected : [0-9]*" /tmp/cg/$TAG.log | sed "s/^/$TAG /"
