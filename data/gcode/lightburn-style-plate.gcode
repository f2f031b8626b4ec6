; A 12 mm plate with a hexagonal hole, in the layout of LightBurn's GRBL output
; GRBL device profile, absolute coords
; Bounds: X44 Y44 to X56 Y56
G00 G17 G40 G21 G54
G90
M4
; Cut @ 8 mm/sec, 40% power
M8
G0 X53Y50
; Layer hole
G1 X51.5Y52.598S400F480
X48.5
X47Y50
X48.5Y47.402
X51.5
X53Y50
; Cut @ 6 mm/sec, 60% power
G0 X44Y44
; Layer outline
G1 Y56S600F360
X56
Y44
X44
M9
G1 S0
M5
G90
; return to user-defined finish pos
G0 X0Y0
M2
