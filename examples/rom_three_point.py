"""ROM three-point curve of a bundle from its effective properties (Sec. 4.3, eq. 13).

The closed-tube CWB of Table 3 (E 15.7 MPa, sigma_Y 0.6 MPa, K 1.59 MPa, n 0.3, outer radius
7.05 mm) on the test's rollers; then the same beam elastic on pinned supports, whose first
slope is the small-deflection 48 E I / L^3 that eq. 13 inverts.

    python examples/rom_three_point.py
"""
import math

import numpy as np

from harnesspipe.rom import three_point

E, SIGMA_Y, K, N, R_O, SPAN = 15.7, 0.6, 1.59, 0.3, 7.05, 127.0

curve = three_point(E=E, sigma_y=SIGMA_Y, K=K, n=N, radius=R_O, supports="rollers")
for u in (5.0, 10.0, 20.0, 30.0):
    print(f"rollers: F({u:g} mm) = {np.interp(u, curve.deflection_mm, curve.force_N):.3f} N")

elastic = three_point(E=E, radius=R_O, supports="pinned", elastic=True, deflection=1.0,
                      n_increments=10)
slope = float(np.polyfit(elastic.deflection_mm, elastic.force_N, 1)[0])
I = math.pi * R_O**4 / 4.0
print(f"pinned, elastic: slope {slope:.4f} N/mm, 48 E I / L^3 = {48 * E * I / SPAN**3:.4f} N/mm")
