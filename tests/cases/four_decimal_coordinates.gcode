; repro: 4-decimal coordinates: the re-timed points are rounded to 3 decimals, up to 0.0015 mm off the original segment (verify fails); the output must keep the input's precision (fuzz, scale mutation) profile=generic-klipper
M83
M204 S1000
;TYPE:FILL
G1 F3000 X98.4143 Y98.1079 E.5
G1 X98.1079 Y100.4936 E.19306
G1 X99.965 Y98.108 E.04549
G1 X130.1234 Y98.1081 E1.1281
