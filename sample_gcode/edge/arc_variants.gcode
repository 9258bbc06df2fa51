; edge case: arcs a firmware runs but that must not be re-timed: an I/J arc whose end is 0.05 mm
; off its circle (firmwares disagree on how to close it: left as written, with a warning), an R-form
; arc, a helical arc (Z changes), and a good I/J arc between them that may be re-timed.
G21
G90
M83
M204 S1500
G1 Z0.2 F720
G1 X110 Y100 F9000
;TYPE:Internal infill
G1 F3000
G3 X100 Y110 I-10 J0 E0.58748
G3 X89.95 Y100 I0 J-10 E0.58748
G1 X90 Y100 F9000
G3 X100 Y90 R10 E0.58748 F3000
G3 X110 Y100 Z0.4 I0 J10 E0.58748
G1 Z0.2 F720
G1 F3000
G2 X90 Y100 I-10 J0 E1.17496
G1 E-.8 F2100
M107
