"""Contact and cohesive interactions (Sec. 4.1, eqs. 6-10), one module per interaction family.

Explicit bundle model (the hi-fi three-point test):

* :mod:`.wire_wire`      wires on wires: penalty normal, eq. 6 friction;
* :mod:`.wire_pins`      wires (beam chains) on the rigid rollers and loading pin, Coulomb;
* :mod:`.facet_pins`     shell facets (tube, tape) on the same cylinders, Coulomb;
* :mod:`.node_facet`     wire nodes on shell facets, one-sided, eq. 6 friction;
* :mod:`.cohesive_ties`  tape bonded to the tube / the wires, eqs. 7-10, with a dashpot;
* :mod:`.tie_targets`    the ties built from the initial geometry (plain Python);

with the conventions and the friction history they share in :mod:`.common`, the quad
surface geometry in :mod:`.surface` and the broad-phase search in :mod:`.search`.
Implicit (the ROM's three-point test): :mod:`.beam_cylinder`, beams on rigid cylinders.
"""
