"""Large-deflection elastic cantilever against the elastica (Bisshopp & Drucker 1945).

A tip dead load P with P L^2 / (E I) = 1 bends the tip by delta_v / L = 0.30172 across the
axis and pulls it in by delta_h / L = 0.05643 along it.

    python examples/cantilever_elastica.py
"""
import math

from harnesspipe.rom import cantilever

E, R, L = 5000.0, 0.7, 100.0
EI = E * math.pi * R**4 / 4.0
curve = cantilever(E=E, radius=R, length=L, tip_load=EI / L**2, elastic=True)
tip = curve.iloc[-1]
print(f"delta_v/L = {tip.tip_uy_mm / L:.5f} (elastica 0.30172), "
      f"delta_h/L = {-tip.tip_ux_mm / L:.5f} (elastica 0.05643)")
