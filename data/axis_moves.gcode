(The single axis: back-and-forth moves along X, some 5 s.)
(X is the carriage's position in its 0-100 mm travel; F, in mm/min, a move's peak speed.)
G21 G90
G0 X10
G1 X40 F2400
G1 X20 F3000
G1 X50 F3600
G0 X10
G1 X30 F1800
M2
