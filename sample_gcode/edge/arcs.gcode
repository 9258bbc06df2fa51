; edge case: G2 (clockwise) / G3 (counter-clockwise) arcs
; I/J = centre offset from the START point; R = radius (R<0: the arc is > 180 deg).
; E values assume 0.45 x 0.2 mm lines (0.0374 mm filament per mm of path).
G21
G90
M83
G1 Z0.2 F720
G1 X100 Y100 F10800
;TYPE:External perimeter
;WIDTH:0.45
; quarter circle, centre (110,100), radius 10, clockwise -> ends at (110,110)
G2 X110 Y110 I10 J0 E0.587 F1800
; quarter circle counter-clockwise, centre (110,120), ends at (120,120)
G3 X120 Y120 I0 J10 E0.587
; full circle: I/J form, explicit end point = start point (centre 130,120)
G2 X120 Y120 I10 J0 E2.350
; full circle: I/J form, end point omitted (= current position)
G3 I10 J0 E2.350
;TYPE:Internal infill
G1 X140 Y120 E0.748 F4800
; R form: half circle (180 deg) from (140,120) to (160,120), radius 10
G2 X160 Y120 R10 E1.175 F4800
; R form, negative radius: 270 deg arc from (160,120) to (170,130), radius 10
G3 X170 Y130 R-10 E1.762
; arc that also moves Z (helix, as in spiral vase / z-hop ramps)
G2 X170 Y130 Z0.4 I-5 J0 E1.175 F1800
; arc with all letters lower case and no spaces
g3x180y130i5j0e0.587f1800
; travel arc without extrusion
G2 X190 Y130 I5 J0 F10800
