(a square whose last two sides run under a local offset, G52: not predicted, and listed)
G21 G90 G17
G0 X200 Y150 Z100
G1 X300 F500
G1 Y250
G52 X5 Y5
G1 X200
G1 Y150
G52 X0 Y0
G0 X200 Y150 Z100
G1 X300
M30
