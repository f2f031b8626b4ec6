; The grinding cell's pass: 0.5 mm along X from where the hexapod stands,
; at 0.1 mm/s (F6: 6 mm/min) with the spindle at 25000 rpm; the normal force
; is the cell's own, 7.5 N.
G21 G90
M3 S25000
G1 X0.5 F6
M5
M2
