; edge case: G92 position resets
; * G92 E0 in absolute E mode (M82): E restarts from 0, next E values are small
; * G92 E0 in relative E mode (M83): harmless, position bookkeeping only
; * G92 X.. Y.. : redefines the current XY position (work offset) without moving
; * G92 Z.. : redefines Z (used by some start scripts after a probe)
G21
G90
M82 ; absolute E
G92 E0
G1 Z0.2 F720
G1 X100 Y100 F10800
;TYPE:Internal infill
G1 X120 Y100 E0.748 F4800
G1 X120 Y102.25 E0.832
G1 X100 Y102.25 E1.580
G92 E0 ; reset: E is now 0 although 1.58 mm of filament were pushed
G1 X100 Y104.5 E0.084
G1 X120 Y104.5 E0.832
G92 E0.0 ; same reset, decimal form
G1 X120 Y106.75 E0.084
; shift the coordinate system: the nozzle is at X120 Y106.75, call it X0 Y0
G92 X0 Y0
G1 X-20 Y0 E0.832 ; really goes to machine X100 Y106.75
G1 X-20 Y2.25 E0.916
G1 X0 Y2.25 E1.664
G92 X120 Y109 ; back to machine coordinates (same physical point)
G1 X120 Y111.25 E1.748
G1 X100 Y111.25 E2.496
M83 ; switch to relative E
G92 E0 ; reset in relative mode
G1 X100 Y113.5 E0.084
G1 X120 Y113.5 E0.748
G92 Z0.2 ; Z redefined to the value it already has
G1 X100 Y115.75 E0.084
G92 ; bare G92, no axes: meaning differs between firmwares (all axes to 0 vs. no-op) - rare, parsers must not crash
