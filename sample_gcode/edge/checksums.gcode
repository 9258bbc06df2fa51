; edge case: line numbers and checksums (RepRap host protocol), e.g. a file
; captured from a host's serial log. 'N<n> <cmd>*<cs>': cs = XOR of all bytes
; before '*'; 'M110 N<n>' sets the number the NEXT line must carry minus one.
; The N word and the *cs are transport, not part of the command.
; Note: the brief's example 'N123 G1 X1 *45' does not carry a valid checksum:
; XOR('N123 G1 X1 ') = 65 (space before '*', used for N123 below) and
; XOR('N123 G1 X1') = 97 (no space, the form used on all other lines).
;TYPE:Internal infill
N0 M110 N0*125
N1 G28 X Y*19
N2 G90*18
N3 M83*27
N4 G1 Z0.2 F720*41
N5 G1 X100 Y100 F10800*115
N6 G1 X120 Y100 E0.748 F4800*7
N7 G1 X120 Y102.25 E0.084*64
N8 G1 X100 Y102.25 E0.748*74
N9 G1 X100 Y104.5 E0.084*120
N10 G1 X120 Y104.5 E0.748*69
N11 G1 E-0.8 F2100*19
N12 M110 N122*79
N123 G1 X1 *65
N124 G1 E0.8 F2100*9
N125 G1 X1 Y100 F10800*112
N126 G1 X20 Y100 E0.711 F4800*57
N127 G1 X20 Y102.25 E0.084*114
N128 G1 X1 Y102.25 E0.711*69
