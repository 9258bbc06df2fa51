; edge case: the different M204 (set acceleration) dialects
;   Marlin 1.x / Prusa firmware (legacy):  M204 S<print+travel> T<retract>
;   Marlin 2:  M204 P<print> R<retract> T<travel>   (S = set P and T together)
;   RepRapFirmware: M204 P<print> T<travel>
;   Klipper: M204 S<accel> or M204 P<..> T<..> (uses min(P,T))
G21
G90
M83
M201 X1000 Y1000 Z200 E5000 ; max accelerations
M203 X200 Y200 Z12 E120 ; max feedrates
M204 P1250 R1250 T1250 ; Marlin 2 style, all three
M205 X8.00 Y8.00 Z0.40 E4.50 ; jerk
G1 Z0.2 F720
M204 S800 ; single value (PrusaSlicer marlin flavor: before perimeters)
;TYPE:Perimeter
G1 X100 Y100 F10800
G1 X120 Y100 E0.748 F2700
M204 P1000 ; print only (PrusaSlicer marlin2 flavor)
;TYPE:Internal infill
G1 X120 Y102.25 E0.084 F4800
G1 X100 Y102.25 E0.748
M204 T1500 ; travel only
G1 X140 Y140 F10800
M204 P2000 T3000 ; print + travel (RepRapFirmware / Marlin 2)
G1 X160 Y140 E0.748 F4800
M204 S1000 T1250 ; legacy Prusa: S = print+travel, T = retract
G1 X160 Y142.25 E0.084
M204 R1250 ; retract only
M204 S1500.5 ; decimal value
G1 X140 Y142.25 E0.748
M204 S1000 ; comment right after the value
m204 s1200 ; lowercase
G1 X140 Y144.5 E0.084
