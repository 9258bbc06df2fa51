; edge case: Prusa-firmware-specific commands (MK3S start G-code)
; M862.x has a dotted sub-code and a quoted string argument; G28 W has a
; parameter letter without a value; G80 = mesh bed levelling; M73 = progress;
; M900 = linear advance; M907 = motor current.
M862.3 P "MK3S" ; printer model check
M862.1 P0.4 ; nozzle diameter check
M115 U3.11.0 ; tell printer latest fw version
G90 ; use absolute coordinates
M83 ; extruder relative mode
M104 S215 ; set extruder temp
M140 S60 ; set bed temp
M190 S60 ; wait for bed temp
M109 S215 ; wait for extruder temp
G28 W ; home all without mesh bed level
G80 ; mesh bed leveling
G1 Z0.2 F720
G1 Y-3 F1000 ; go outside print area
G92 E0
G1 X60 E9 F1000 ; intro line
G1 X100 E12.5 F1000 ; intro line
G92 E0
M221 S95
M907 E430 ; set extruder motor current
M900 K30 ; Filament gcode LA 1.0
M73 P0 R18
M73 Q0 S18
;TYPE:Internal infill
;WIDTH:0.45
G1 X100 Y100 F10800
G1 X120 Y100 E0.748 F4800
G1 X120 Y102.25 E0.084
G1 X100 Y102.25 E0.748
M73 P50 R9
G1 X100 Y104.5 E0.084
G1 X120 Y104.5 E0.748
