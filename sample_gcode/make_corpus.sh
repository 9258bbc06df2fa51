#!/usr/bin/env bash
# make_corpus.sh - slice a corpus of large, real slicer files of the kinds that broke
# gcode-opt (issue 7), for corpus tests and manual runs. NOT committed output: the
# files are large (up to ~15 MB); they go to a folder given as argument.
#
# WHAT IT MAKES (in OUT_DIR, default ${XDG_CACHE_HOME:-~/.cache}/gcode-opt-corpus):
#   gyroid_fwretract.gcode  PrusaSlicer (prusa_mk3s.ini), 30 x 20 mm cylinder, gyroid 15 %,
#                           use_firmware_retraction = 1 (G10/G11 instead of E moves).
#   plate_rectilinear.gcode PrusaSlicer, a plate of mixed boxes and cylinders, rectilinear
#                           20 % (~190 k lines).
#   plate_gyroid.gcode      PrusaSlicer, a plate of four 40 x 25 mm cylinders, gyroid 15 %
#                           (~440 k lines).
#   bridges.gcode           PrusaSlicer, an arch, a box with a window and a flared hull
#                           (bridges, overhangs), rectilinear 20 %.
#   bridges_klipper.gcode   the same plate with prusa_klipper.ini (marlin2 flavour, Klipper
#                           macros, 3000-4000 mm/s^2 accelerations).
#   no_type_comments.gcode  bridges.gcode with every ";TYPE:" line removed (sed): PrusaSlicer
#                           2.5 writes ;TYPE: even with gcode_comments = 0, so a file without
#                           feature comments (as some slicers/post-processors leave) is made
#                           by hand from a real one.
#   cura_gyroid.gcode       CuraEngine 4.13, Ender-3 definition, the 30 x 20 mm cylinder,
#                           gyroid 20 %, acceleration control on (as make_samples.sh).
#   cura_bridges.gcode      CuraEngine, the arch and the window box.
# STL models come from corpus_models.py (this folder), written into a temp dir.
#
# WHAT IT NEEDS: python3, prusa-slicer, CuraEngine and Cura's definition files, found or
# fetched exactly as make_samples.sh does (see its header).
#
# USAGE:   bash sample_gcode/make_corpus.sh [OUT_DIR]
# Takes ~30 s on 2 cores (plus a one-time 25 MB download of the Cura definitions). Existing files are kept
# unless FORCE=1 (slicing is deterministic apart from the date line).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-${XDG_CACHE_HOME:-$HOME/.cache}/gcode-opt-corpus}"
PRUSA="${PRUSA_SLICER:-prusa-slicer}"
CURA="${CURA_ENGINE:-CuraEngine}"
mkdir -p "$OUT"
OUT="$(cd "$OUT" && pwd)"

for tool in python3 "$PRUSA"; do
    command -v "$tool" >/dev/null 2>&1 || { echo "make_corpus.sh: '$tool' not found" >&2; exit 1; }
done

WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
python3 "$HERE/corpus_models.py" "$WORK"

want() { [ "${FORCE:-0}" = 1 ] || [ ! -s "$OUT/$1" ]; }

prusa() {  # prusa OUTPUT "MODEL..." [extra prusa-slicer args...]
    local out="$1" models="$2"; shift 2
    want "$out" || { echo "kept $out"; return 0; }
    local stls=()
    for m in $models; do stls+=("$WORK/$m.stl"); done
    # --merge: several models become one arranged plate (without it the CLI keeps only the last)
    "$PRUSA" --export-gcode --merge --load "$HERE/prusa_mk3s.ini" "$@" \
        --output "$OUT/$out" "${stls[@]}" >"$WORK/$out.log" 2>&1 || {
        tail -n 30 "$WORK/$out.log" >&2; echo "make_corpus.sh: PrusaSlicer failed for $out" >&2; exit 1; }
    echo "wrote $out"
}

prusa gyroid_fwretract.gcode cylinder_d30x20 \
    --fill-pattern gyroid --fill-density 15% --use-firmware-retraction --no-wipe
prusa plate_rectilinear.gcode \
    "box_30x30x20 box_30x30x20 box_30x30x20 box_50x20x15 box_50x20x15 box_20x20x30 box_20x20x30 box_20x20x30 \
     cylinder_d30x20 cylinder_d30x20 cylinder_d30x20 cylinder_d40x10" \
    --fill-pattern rectilinear --fill-density 20%
prusa plate_gyroid.gcode "cylinder_d40x25 cylinder_d40x25 cylinder_d40x25 cylinder_d40x25" \
    --fill-pattern gyroid --fill-density 15%
prusa bridges.gcode "arch window_box hull" --fill-pattern rectilinear --fill-density 20%
prusa bridges_klipper.gcode "arch window_box hull" --load "$HERE/prusa_klipper.ini"
if want no_type_comments.gcode; then
    grep -v '^;TYPE:' "$OUT/bridges.gcode" >"$OUT/no_type_comments.gcode"
    echo "wrote no_type_comments.gcode"
fi

# -------------------------------------------------------------- CuraEngine ---
if ! command -v "$CURA" >/dev/null 2>&1; then
    echo "make_corpus.sh: '$CURA' not found: Cura files skipped" >&2
else
    . "$HERE/cura_resources.sh"
    CURA_RES="$(find_cura_resources)"
    export CURA_ENGINE_SEARCH_PATH="$CURA_RES/definitions:$CURA_RES/extruders"
    # make_samples.sh's Ender-3 "Standard Quality" settings (formulas evaluated by hand),
    # acceleration control on; the infill pattern is given per file.
    CURA_SETTINGS=(
        layer_height=0.2 layer_height_0=0.2 line_width=0.4
        wall_thickness=0.8 wall_line_count=2
        top_bottom_thickness=0.8 top_thickness=0.8 bottom_thickness=0.8
        top_layers=4 bottom_layers=4 initial_bottom_layers=4
        infill_sparse_thickness=0.2 infill_overlap=30 infill_overlap_mm=0.12
        skin_overlap=10 skin_overlap_mm=0.04 infill_wipe_dist=0 wall_0_wipe_dist=0
        z_seam_type=back optimize_wall_printing_order=true
        speed_print=50 speed_infill=50 speed_wall=25 speed_wall_0=25 speed_wall_x=25
        speed_topbottom=25 speed_roofing=25 speed_travel=150
        speed_layer_0=20 speed_print_layer_0=20 speed_travel_layer_0=100 skirt_brim_speed=20
        machine_acceleration=500 acceleration_enabled=true
        acceleration_print=1000 acceleration_infill=1000 acceleration_topbottom=1000
        acceleration_roofing=1000 acceleration_wall=500 acceleration_wall_0=500
        acceleration_wall_x=500 acceleration_travel=1500 acceleration_layer_0=500
        acceleration_print_layer_0=500 acceleration_travel_layer_0=1000
        acceleration_skirt_brim=500 jerk_enabled=false
        retraction_enable=true retraction_amount=6.5 retraction_speed=25
        retraction_retract_speed=25 retraction_prime_speed=25
        retraction_combing=noskin retraction_min_travel=1.5
        adhesion_type=skirt skirt_line_count=3 skirt_gap=10
        material_print_temperature=200 material_print_temperature_layer_0=200
        material_bed_temperature=60 material_bed_temperature_layer_0=60
        machine_end_gcode=M84
    )
    cura() {  # cura OUTPUT "MODEL..." [extra -s settings...]
        local out="$1" models="$2"; shift 2
        want "$out" || { echo "kept $out"; return 0; }
        local args=()
        for s in "${CURA_SETTINGS[@]}" "$@"; do args+=(-s "$s"); done
        # one object per -l; CuraEngine does not arrange, so each model is moved with mesh_position_x
        local models_args=() x=-45
        for m in $models; do models_args+=(-l "$m.stl" -s "mesh_position_x=$x"); x=$((x + 55)); done
        (cd "$WORK" && "$CURA" slice -j "$CURA_RES/definitions/creality_ender3.def.json" \
            "${args[@]}" "${models_args[@]}" -o "$OUT/$out") >"$WORK/$out.log" 2>&1 || {
            tail -n 30 "$WORK/$out.log" >&2; echo "make_corpus.sh: CuraEngine failed for $out" >&2; exit 1; }
        echo "wrote $out"
    }
    cura cura_gyroid.gcode cylinder_d30x20 infill_sparse_density=20 infill_pattern=gyroid \
        infill_line_distance=2
    cura cura_bridges.gcode "arch window_box" infill_sparse_density=20 infill_pattern=cubic \
        infill_line_distance=6
fi

for f in "$OUT"/*.gcode; do
    printf '%-28s %10d bytes %8d lines\n' "$(basename "$f")" "$(wc -c <"$f")" "$(wc -l <"$f")"
done
