; repro: 'M201 X-1000 Y-1000': exit 2 with 'math domain error', no line named (HEAD 4810345; fuzz) profile=generic-marlin features=all
M201 X-1000 Y-1000
G1 X115.828 Y106.01 E.01941
G1 X113.644 Y106.241 E.01708
