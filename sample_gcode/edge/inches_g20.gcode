; edge case: G20 (inch units)
; Every X/Y/Z/E/F value between G20 and G21 is in inches (F in inch/min).
; The two infill lines in inches are identical to the two in millimetres below.
G90
M83
G21 ; millimetres first
G1 Z0.2 F720
G1 X100 Y100 F10800
;TYPE:Internal infill
G1 X125.4 Y100 E0.950 F4800 ; 25.4 mm line
G20 ; from here on: inches
G1 X4.937008 Y4.025591 F425.197 ; travel to X125.4 Y102.25 mm at 180 mm/s
G1 X3.937008 E0.0374 F188.976 ; 1 inch (25.4 mm) line back to X100 mm at 80 mm/s
G1 Y4.114173 E0.0033 ; 0.088583 in = 2.25 mm step
G1 X4.937008 E0.0374 ; another 1 inch line
G1 Z0.015748 F28.346 ; 0.4 mm
G21 ; back to millimetres
G1 X110 Y110 F10800
G1 X120 Y110 E0.374 F4800
