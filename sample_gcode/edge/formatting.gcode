; edge case: formatting that parsers must tolerate
;   comment-only lines, blank lines, whitespace-only lines, trailing spaces
;   and tabs, leading whitespace, lower-case words, words without spaces,
;   numbers without leading zero (E.5, E-.8), explicit '+' sign.
G21
G90
M83


;TYPE:Internal infill
   
	
G1 Z0.2 F720   
G1 X10 Y23.4 F10800	
G1 X10Y10E.5 F4800
G1X30Y10E.748
g1 x30 y12.25 e0.084
g1 x10 y12.25 e0.748 ; lower-case with a comment   
  G1 X10 Y14.5 E0.084
	G1 X30 Y14.5 E0.748
;just a comment, no space after the semicolon
;
G1 X30 Y16.75 E+0.084 ; explicit plus sign
G1  X10   Y16.75   E0.748 ; several spaces between words
G1 E-.8 F2100
G0 X50 Y50 F10800
G1 E.8 F2100
G01 X70 Y50 E0.748 F4800 ; G01 = G1 with leading zero
G1 X70 Y50.0 E0.0 ; zero-length move with E0

