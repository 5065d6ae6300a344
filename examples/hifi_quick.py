"""A quick high-fidelity virtual three-point test of the closed-tube CWB (Sec. 4.1).

19 type-2 wires in the ridged closed tube, the quick mesh, the interface at its config start
values; the run stops at STOP mm of the 30 mm stroke to stay short (default 15; at least a
third of the stroke, where the KE/IE check starts).  It prints the force at a few deflections
and the run's energy checks.

    python examples/hifi_quick.py [STOP]
"""
import sys

import numpy as np

from harnesspipe.config import load
from harnesspipe.models.hifi import three_point
from harnesspipe.stages.hifi import inputs

stop = float(sys.argv[1]) if len(sys.argv) > 1 else 15.0
cfg = load()
cfg["profile"] = "quick"
run = three_point(inputs(cfg, "cwb19_t2_closed", {"stop_deflection": str(stop)}), n_shapes=1)
u, F = run.curve["deflection_mm"], run.curve["force_N"]
for d in np.linspace(stop / 4.0, stop, 4):
    print(f"F({d:.1f} mm) = {np.interp(d, u, F):.3f} N")
s = run.summary
print(f"{s['steps']} steps of {s['dt']:.3g} s in {s['wall_s']:.1f} s; KE/IE {s['ke_ie_max']:.3g}, "
      f"energy error {s['energy_error']:.2g}")
