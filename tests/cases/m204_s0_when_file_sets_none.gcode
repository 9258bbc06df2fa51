; repro: a file that never sets an acceleration: the re-timed block restored it as 'M204 S0' (HEAD 4810345; fuzz) profile=prusa-mk3s features=all
G1 F4583
G1 X144.063 Y88.42 E1.33602
G1 X144.063 Y87.921 E.01691
G1 X142.079 Y85.937 E.09494
G1 X141.58 Y85.937 E.01691
