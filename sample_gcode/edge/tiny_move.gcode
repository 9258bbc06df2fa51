; edge case: very short moves (0.01 mm and below), as produced by slicers at
; polygon vertices / seam closing. Optimisers must not divide by zero or drop
; the extrusion, and must keep E for moves that extrude.
G21
G90
M83
G1 Z0.2 F720
G1 X100 Y100 F10800
;TYPE:Internal infill
;WIDTH:0.45
G1 X120 Y100 E0.748 F4800
G1 X120.01 Y100 E0.00037 ; 0.01 mm extruding move
G1 X120.01 Y100.01 E0.00037 ; another 0.01 mm, perpendicular
G1 X120.011 Y100.01 E0.00004 ; 0.001 mm
G1 X120.011 Y102.25 E0.084
G1 X100 Y102.25 E0.748
G1 X100.01 Y102.25 F10800 ; 0.01 mm travel
G1 X100 Y102.25 ; and back
G1 X100 Y102.26 E0.00037 F4800 ; 0.01 mm extruding move in Y
G1 X100 Y104.5 E0.084
G1 X120 Y104.5 E0.748
G1 Z0.21 F720 ; 0.01 mm Z-only move
G1 Z0.2
G1 E0.01 F2100 ; 0.01 mm extruder-only move
G1 X120 Y104.5 E0.01 ; zero-length XY move with E (pure extrusion)
