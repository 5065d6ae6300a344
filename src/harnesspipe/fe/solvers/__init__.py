"""Solvers: static Newton path following with a band LU (beams) and with dense tangents
(shells), implicit Newmark with banded tangents, and explicit central differences with
energy accounting per force family."""
