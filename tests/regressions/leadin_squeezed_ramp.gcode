; regression (issue 7): a lead-in at the corner speed squeezed the next ramp into a shorter segment:
; its acceleration (563 mm/s^2) exceeded the machine's 500 (ender3) -> validator reject (random arc fuzz)
G21
G90
M83
M204 S500
G1 Z0.2 F720
G1 X100 Y100 F9000
;TYPE:Internal infill
G1 X1213.433 Y1151.401 E0.1 F6000
G2 X473.453 Y1686.187 I-405.310 J218.521 E58.62592 F12000
G1 X475.754 Y1687.436 E0.1 F12000
G3 X509.526 Y1701.978 I16.579 J7.983 E2.10404 F6000
