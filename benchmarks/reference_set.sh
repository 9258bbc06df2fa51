#!/bin/bash
# The lead's same-bits check between two trees: the default command (and 8 option variants)
# over every bundled sample, edge file and corpus file (sample_gcode/make_corpus.sh).
#   bash benchmarks/reference_set.sh run TREE OUT     # OUT/<case>.gcode, .json (volatile keys dropped), .rc, .err
#   bash benchmarks/reference_set.sh cmp OUT_A OUT_B  # every file byte for byte; prints "files=N bad=M"
# PYTHON: the interpreter (default python3).  Session 53: 48 cases, 192 files.
set -u
PY=${PYTHON:-python3}
HERE=$(cd "$(dirname "$0")" && pwd)
S=$(cd "$HERE/../sample_gcode" && pwd)
C=${XDG_CACHE_HOME:-$HOME/.cache}/gcode-opt-corpus

run_case() {  # name file args...
  name=$1; f=$2; shift 2
  (cd "$TREE" && PYTHONPATH=$TREE nice -n 5 $PY -m gcode_opt process "$f" -o "$OUT/$name.gcode" \
      --json "$OUT/$name.json.raw" -q "$@" 2> "$OUT/$name.err"; echo $? > "$OUT/$name.rc")
  if [ -f "$OUT/$name.json.raw" ]; then
    $PY -c "import json,sys; d=json.load(open(sys.argv[1])); [d.pop(k,None) for k in ('timing_s','elapsed_s','output')]; json.dump(d,open(sys.argv[2],'w'),sort_keys=True,indent=0)" \
        "$OUT/$name.json.raw" "$OUT/$name.json" && rm "$OUT/$name.json.raw"
  fi
  sed -i "s#$TREE#TREE#g; s#$OUT#OUT#g" "$OUT/$name.err"
}

case ${1:-} in
run)
  TREE=$(cd "$2" && pwd); mkdir -p "$3"; OUT=$(cd "$3" && pwd)
  for f in "$S"/*.gcode; do run_case "$(basename "$f" .gcode)" "$f"; done
  for f in "$S"/edge/*.gcode; do run_case "edge_$(basename "$f" .gcode)" "$f"; done
  for f in "$C"/*.gcode; do [ -f "$f" ] && run_case "corpus_$(basename "$f" .gcode)" "$f"; done
  [ -f "$C/plate_gyroid.gcode" ] && run_case plate_gyroid_v24 "$C/plate_gyroid.gcode" --profile voron24
  run_case gyroid_all "$S/prusa_gyroid.gcode" --features all
  run_case gyroid_alpha "$S/prusa_gyroid.gcode" --alpha 0.002
  run_case gyroid_corners "$S/prusa_gyroid.gcode" --corners auto
  run_case klipper_corners "$S/prusa_klipper.gcode" --corners 0.7
  run_case arcs_all "$S/prusa_gyroid_arcs.gcode" --features all
  run_case rect_slow "$S/prusa_mk3s_rectilinear.gcode" --max-slowdown 0.001
  run_case gyroid_seg3 "$S/prusa_gyroid.gcode" --segments 3 --max-turn 0
  ;;
cmp)
  bad=0; n=0
  for f in "$2"/*; do b=$(basename "$f"); n=$((n+1)); cmp -s "$f" "$3/$b" || { echo "DIFF $b"; bad=$((bad+1)); }; done
  for f in "$3"/*; do b=$(basename "$f"); [ -e "$2/$b" ] || { echo "ONLY-B $b"; bad=$((bad+1)); }; done
  echo "files=$n bad=$bad"
  ;;
*) sed -n 2,6p "$0"; exit 2 ;;
esac
