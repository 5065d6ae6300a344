"""The FE core's hot loops are compiled without reference counting (harnesspipe.fe.loops).

Their results are the same with and without the counts (the four quick CWB runs hash the
same, bench/RESULTS.md); what is checked here is the decorator's contract: no count in the
compiled loop, no allocation accepted, and the lanes' loops carry it.
"""
import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from harnesspipe.fe.contact import (cohesive_ties, common, facet_pins, node_facet, surface, wire_pins,
                                    wire_wire)
from harnesspipe.fe.elements import beam_explicit, shell_bt
from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.rotation import quat_to_matrix


@njit(inline="always")
def _weighted_row(state, e, out, w):
    """A helper inlined per element that takes its arrays and a view, as the element kernels do."""
    row = state[e]
    s = 0.0
    for i in range(row.shape[0]):
        s += row[i] * w[i % w.shape[0]] if row[i] > 0.0 else -row[i]
    out[e] = s


def _loop(state, out, w):
    for e in range(state.shape[0]):
        if state[e, 0] > 0.5:
            _weighted_row(state, e, out, w)
        else:
            _weighted_row(state, e, out, w[1:])


def _allocating(n):
    return np.zeros(n).sum()


def _increfs(dispatcher):
    return sum(ir.count("@NRT_incref") for ir in dispatcher.inspect_llvm().values())


def test_loop_kernel_counts_no_references_and_gives_the_same_result():
    rng = np.random.default_rng(0)
    state, w = rng.normal(size=(50, 7)), rng.normal(size=3)
    counted, uncounted, expected = np.empty(50), np.empty(50), np.empty(50)
    counting = njit(_loop)
    counting(state, counted, w)
    kernel = loop_kernel(_loop)
    kernel(state, uncounted, w)
    for e in range(50):
        ws = w if state[e, 0] > 0.5 else w[1:]
        expected[e] = sum(r * ws[i % ws.size] if r > 0.0 else -r for i, r in enumerate(state[e]))
    assert np.array_equal(counted, uncounted)
    assert np.allclose(uncounted, expected, rtol=1e-14)
    assert _increfs(counting) > 0          # the counts this removes
    assert _increfs(kernel) == 0


def test_loop_kernel_refuses_an_allocation():
    with pytest.raises(TypingError):
        loop_kernel(_allocating)(3)


@pytest.mark.parametrize("kernel", [
    shell_bt._element_loop, beam_explicit._beam_loop, wire_wire._ww_flags, wire_wire._ww_forces,
    wire_wire._ww_commit, node_facet._nf_project, node_facet._nf_softmin,
    node_facet._nf_node_forces, cohesive_ties._quad_ties_range, cohesive_ties._quad_ties_commit,
    cohesive_ties._beam_ties, wire_pins._chain_pins, facet_pins._facet_pins, facet_pins._facets_near,
    facet_pins._quad_axis_closest, facet_pins._patches, surface.project_quad, common.find_slot,
    common.free_slot, quat_to_matrix])
def test_the_lanes_loops_are_loop_kernels(kernel):
    assert kernel.targetoptions.get("_nrt") is False, kernel.py_func.__qualname__
