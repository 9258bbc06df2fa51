; repro: 'Y-inf' in a motion line was accepted and written back, exit 0 (HEAD 4810345; fuzz) profile=bambu-x1c
G1 X124.228 Y-inf E-.0894
