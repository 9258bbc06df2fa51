; regression (issue 7): a curve whose end segment is > 38 x the smoothing width
; (28 mm line + three 0.5-0.6 mm connectors): the curvature kernel underflowed -> NaN -> crash
G21
G90
M83
M204 S1500
G1 Z0.2 F720
G1 X50 Y50 F9000
;TYPE:Internal infill
;WIDTH:0.45
G1 X78.000 Y50.000 E1.04720 F2400
G1 X78.599 Y50.042 E0.02244 F2400
G1 X79.094 Y50.111 E0.01870 F2400
G1 X79.583 Y50.215 E0.01870 F2400
G1 X69.583 Y65.215 E0.67320
G1 E-0.8 F2100
G1 Z0.4 F720
G1 X50 Y50 F9000
