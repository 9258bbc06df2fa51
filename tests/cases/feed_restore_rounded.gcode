; repro: a feed with 4 significant digits (F0.1884) is restored as 'G1 F0.188' after the block (modal state differs; the block itself runs at F6, 30x the slicer's F) (fuzz at 28f898f) profile=generic-klipper
;TYPE:Internal infill
G1 F0.1884
G1 X117.575 Y93.529 E.01505
G1 X120.632 Y92.264 E.04176
