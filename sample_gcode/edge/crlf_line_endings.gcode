; edge case: Windows CRLF line endings (every line of this file ends in \r\n)
; otherwise an ordinary PrusaSlicer-style fragment with relative E
G21
G90
M83
;LAYER_CHANGE
;Z:0.2
G1 Z0.2 F720
M204 S800
;TYPE:Perimeter
;WIDTH:0.45
G1 X100 Y100 F10800
G1 X120 Y100 E0.748 F2700
G1 X120 Y120 E0.748
M204 S1000
;TYPE:Internal infill
G1 X101 Y102 F10800
G1 X119 Y102 E0.673 F4800
G1 X119 Y104.25 E0.084
G1 X101 Y104.25 E0.673
G1 X101 Y106.5 E0.084
G1 X119 Y106.5 E0.673
G1 E-0.8 F2100
