; edge case: G91 relative XYZ moves in the middle of a print
; Marlin: G91 makes X/Y/Z and E relative; G90 makes all of them (E too!) absolute,
; so slicers always send M83 again after G90.
; The infill zig-zag below is printed twice: once with absolute XY (G90), once
; with relative XY (G91) one layer up. Both give the same XY path.
G21 ; millimetres
G90 ; absolute XYZ
M83 ; relative E
G92 E0
G1 Z0.2 F720
;TYPE:Internal infill
;WIDTH:0.45
G1 X100 Y100 F10800 ; travel (absolute)
G1 X120 Y100 E0.748 F4800
G1 X120 Y102.25 E0.084
G1 X100 Y102.25 E0.748
G1 X100 Y104.5 E0.084
G1 X120 Y104.5 E0.748
; same zig-zag again, one layer up, written with relative coordinates
G91 ; relative XYZ from here on
G1 Z0.2 F720 ; +0.2 mm -> Z0.4
G1 X-20 Y-4.5 F10800 ; travel back to X100 Y100
G1 X20 E0.748 F4800
G1 Y2.25 E0.084
G1 X-20 E0.748
G1 Y2.25 E0.084
G1 X20 E0.748
G1 E-0.8 F2100 ; retract (E is relative anyway: M83)
G1 Z0.4 F720 ; lift +0.4 -> Z0.8
G90 ; back to absolute
M83 ; Marlin: G90/G91 also switch E, so G90 made E absolute again - re-assert relative E
G1 X110 Y110 F10800 ; absolute travel
G1 Z0.4 F720 ; absolute Z again
G1 E0.8 F2100 ; unretract
G1 X110 Y115 E0.187 F4800 ; short infill line, absolute
