; edge case: Klipper extended commands and macros
; Klipper commands are words, not G/M codes, and take NAME=VALUE parameters.
; They must be passed through untouched (and SET_VELOCITY_LIMIT ACCEL= is the
; Klipper way of changing acceleration, alongside M204).
M190 S0 ; Prevents prusaslicer from prepending m190 to the gcode interfering with the macro
M109 S0 ; Prevents prusaslicer from prepending m109 to the gcode interfering with the macro
PRINT_START EXTRUDER=215 BED=60
G21
G90
M83
EXCLUDE_OBJECT_DEFINE NAME=box_id_0_copy_0 CENTER=110,102 POLYGON=[[100,100],[120,100],[120,104],[100,104]]
SET_VELOCITY_LIMIT ACCEL=3000 ACCEL_TO_DECEL=1500 SQUARE_CORNER_VELOCITY=5
G92 E0
G1 Z0.2 F15000
EXCLUDE_OBJECT_START NAME=box_id_0_copy_0
;TYPE:External perimeter
G1 X100 Y100 F15000
G1 X120 Y100 E0.748 F7200
SET_VELOCITY_LIMIT ACCEL=5000
;TYPE:Internal infill
;WIDTH:0.45
G1 X120 Y102.25 E0.084 F9600
G1 X100 Y102.25 E0.748
G1 X100 Y104.5 E0.084
G1 X120 Y104.5 E0.748
SET_VELOCITY_LIMIT ACCEL=3000
set_velocity_limit accel=2500 ; Klipper accepts lowercase command names too
SET_PRESSURE_ADVANCE ADVANCE=0.04
M204 S4000 ; Klipper also understands M204
G1 X110 Y110 E0.5 F9600
EXCLUDE_OBJECT_END NAME=box_id_0_copy_0
SET_VELOCITY_LIMIT ACCEL=3000 ; reset
PRINT_END
