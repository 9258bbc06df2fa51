; regression (issue 7): a lead-in shortened to fit the machine's acceleration left a ~1e-15 mm sliver segment:
; 0/0 -> NaN acceleration (fault isolation kept the original; now no sliver edges). ender3, random arc fuzz
G21
G90
M83
M204 S500
G1 Z0.2 F720
G1 X100 Y100 F9000
;TYPE:Internal infill
G3 X60.119 Y-57.841 I-24.074 J2.119 E4.09951 F1800
G3 X60.403 Y-53.364 I15.592 J1.258 E3.50758 F6000
G1 X59.732 Y-56.838 E0.1 F6000
G2 X-2171.456 Y-2160.628 I-622.191 J-1575.176 E254.55277 F6000
