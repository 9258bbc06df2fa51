; repro: Klipper flavour, no acceleration in the file: 'M204 S0' written after the block (HEAD 4810345; fuzz) profile=voron24
M83 ; use relative distances for extrusion
;TYPE:Internal infill
G1 X144.063 Y88.42 E1.33602
G1 X144.063 Y87.921 E.01691
G1 X142.079 Y85.937 E.09494
G1 X141.58 Y85.937 E.01691
