; repro: a tiny acceleration (M204 S0.0001) is restored rounded after a re-timed block: 'M204 S0' (HEAD 4810345) or 'M204 S0.001' profile=voron24
M204 S0.0001
;TYPE:Internal infill
G1 X129.083 Y85.937 E.00362
G1 X119.556 Y124.063 E.02332
G1 X105.937 Y111.133 E.02332
