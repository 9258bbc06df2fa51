; repro: a 129520 mm coordinate in a curve: exit 2 with scipy's '`y` must contain only finite values.', no line named (HEAD 4810345; fuzz) profile=voron24 features=all
G1 X129520 Y118.316 E.03115
G1 X128.64 Y118.583 E.03115
G1 X127.743 Y118.792 E.03115
G1 X126.835 Y118.942 E.03115
