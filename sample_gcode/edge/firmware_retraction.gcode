; edge case: firmware retraction (G10 retract / G11 recover), as emitted by
; PrusaSlicer/SuperSlicer with use_firmware_retraction = 1 (Marlin FWRETRACT,
; Klipper [firmware_retraction]). The retraction length/speed live in the
; firmware (M207/M208), not in the G-code moves.
G21
G90
M83
M207 S0.8 F2100 Z0 ; Marlin: set retract length/feedrate/z-lift
M208 S0 F2100 ; Marlin: extra recover length/feedrate
G1 Z0.2 F720
G1 X100 Y100 F10800
G11 ; recover (prime) before printing
;TYPE:Internal infill
;WIDTH:0.45
G1 X120 Y100 E0.748 F4800
G1 X120 Y102.25 E0.084
G1 X100 Y102.25 E0.748
G10 ; retract before the travel
G1 X140 Y140 F10800
G11 ; recover
G1 X160 Y140 E0.748 F4800
G1 X160 Y142.25 E0.084
G1 X140 Y142.25 E0.748
G10 ; retract
G1 Z0.4 F720
G1 X100 Y100 F10800
G11
G1 X120 Y100 E0.748 F4800
G10 S1 ; Marlin multi-extruder "swap" retraction form
G11
