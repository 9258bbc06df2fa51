#!/usr/bin/env bash
# make_large.sh - slice the two large real files the speed benchmark runs on (issue 8).
# NOT committed output: ~12 MB and ~5 MB; they go to a folder given as argument.
#
# WHAT IT MAKES (in OUT_DIR, default ${XDG_CACHE_HOME:-~/.cache}/gcode-opt-large):
#   plate_gyroid.gcode       PrusaSlicer (prusa_mk3s.ini), four 40 x 25 mm cylinders on one
#                            plate, gyroid 15 %  (~460 k lines, 12.5 MB)
#   plate_rectilinear.gcode  PrusaSlicer (prusa_mk3s.ini), twelve boxes and cylinders,
#                            rectilinear 20 %  (~186 k lines, 4.7 MB)
# The same plates as make_corpus.sh's (same models, same settings), made here on their own
# so the benchmark does not need the rest of the corpus or CuraEngine.
#
# WHAT IT NEEDS: python3 and prusa-slicer (Debian package "prusa-slicer", 2.5.0); the STL
# models are written by the inline python below into a temp dir (no downloads).
#
# USAGE:   bash sample_gcode/make_large.sh [OUT_DIR]
#          python benchmarks/bench_pipeline.py OUT_DIR/plate_gyroid.gcode
# ~1 min on 2 cores. Existing files are kept unless FORCE=1 (slicing is deterministic
# apart from PrusaSlicer's date line).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-${XDG_CACHE_HOME:-$HOME/.cache}/gcode-opt-large}"
PRUSA="${PRUSA_SLICER:-prusa-slicer}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"
for tool in python3 "$PRUSA"; do
    command -v "$tool" >/dev/null 2>&1 || { echo "make_large.sh: '$tool' not found" >&2; exit 1; }
done

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT

# ---------------------------------------------------------------- geometry ---
# ASCII STLs centred on (0,0), standing on z=0 (PrusaSlicer arranges the plate itself).
python3 - "$WORK" <<'PY'
import math, sys
out = sys.argv[1]

def facet(f, a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = (u[1]*v[2] - u[2]*v[1], u[2]*v[0] - u[0]*v[2], u[0]*v[1] - u[1]*v[0])
    l = math.sqrt(sum(x*x for x in n)) or 1.0
    f.write(" facet normal %g %g %g\n  outer loop\n" % tuple(x / l for x in n))
    for p in (a, b, c):
        f.write("   vertex %.6f %.6f %.6f\n" % p)
    f.write("  endloop\n endfacet\n")

def box(name, sx, sy, sz):
    x0, y0, x1, y1 = -sx/2, -sy/2, sx/2, sy/2
    v = [(x0,y0,0), (x1,y0,0), (x1,y1,0), (x0,y1,0),
         (x0,y0,sz), (x1,y0,sz), (x1,y1,sz), (x0,y1,sz)]
    quads = [(0,3,2,1), (4,5,6,7), (0,1,5,4), (1,2,6,5), (2,3,7,6), (3,0,4,7)]
    with open(f"{out}/{name}.stl", "w") as f:
        f.write(f"solid {name}\n")
        for a, b, c, d in quads:          # counter-clockwise seen from outside
            facet(f, v[a], v[b], v[c]); facet(f, v[a], v[c], v[d])
        f.write(f"endsolid {name}\n")

def cylinder(name, d, h, n=96):
    r = d / 2
    pts = [(r*math.cos(2*math.pi*i/n), r*math.sin(2*math.pi*i/n)) for i in range(n)]
    with open(f"{out}/{name}.stl", "w") as f:
        f.write(f"solid {name}\n")
        for i in range(n):
            (ax, ay), (bx, by) = pts[i], pts[(i + 1) % n]
            facet(f, (0,0,0), (bx,by,0), (ax,ay,0))          # bottom
            facet(f, (0,0,h), (ax,ay,h), (bx,by,h))          # top
            facet(f, (ax,ay,0), (bx,by,0), (bx,by,h))        # side
            facet(f, (ax,ay,0), (bx,by,h), (ax,ay,h))
        f.write(f"endsolid {name}\n")

box("box_30x30x20", 30, 30, 20)
box("box_50x20x15", 50, 20, 15)
box("box_20x20x30", 20, 20, 30)
cylinder("cylinder_d30x20", 30, 20)
cylinder("cylinder_d40x10", 40, 10)
cylinder("cylinder_d40x25", 40, 25)
PY

# ------------------------------------------------------------- PrusaSlicer ---
prusa() {  # prusa OUTPUT "MODEL..." [extra prusa-slicer args...]
    local out="$1" models="$2"; shift 2
    if [ "${FORCE:-0}" != 1 ] && [ -s "$OUT/$out" ]; then echo "kept $out"; return 0; fi
    local stls=()
    for m in $models; do stls+=("$WORK/$m.stl"); done
    # --merge: several models become one arranged plate (without it the CLI keeps only the last)
    "$PRUSA" --export-gcode --merge --load "$HERE/prusa_mk3s.ini" "$@" \
        --output "$OUT/$out" "${stls[@]}" >"$WORK/$out.log" 2>&1 || {
        tail -n 30 "$WORK/$out.log" >&2; echo "make_large.sh: PrusaSlicer failed for $out" >&2; exit 1; }
    echo "wrote $out"
}

prusa plate_gyroid.gcode "cylinder_d40x25 cylinder_d40x25 cylinder_d40x25 cylinder_d40x25" \
    --fill-pattern gyroid --fill-density 15%
prusa plate_rectilinear.gcode \
    "box_30x30x20 box_30x30x20 box_30x30x20 box_50x20x15 box_50x20x15 box_20x20x30 box_20x20x30 box_20x20x30 \
     cylinder_d30x20 cylinder_d30x20 cylinder_d30x20 cylinder_d40x10" \
    --fill-pattern rectilinear --fill-density 20%

for f in plate_gyroid plate_rectilinear; do
    printf '%-26s %9d bytes %7d lines\n' "$f.gcode" "$(wc -c <"$OUT/$f.gcode")" "$(wc -l <"$OUT/$f.gcode")"
done
