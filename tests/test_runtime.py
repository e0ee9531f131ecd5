"""Process settings: freed temporaries are reused instead of faulted in again."""

from __future__ import annotations

import resource
import sys

import numpy as np
import pytest

from fe_impact.runtime import keep_freed_memory


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt")
def test_temporaries_are_not_faulted_in_again():
    # 50 temporaries of 4 MB (1,000 pages each): mapped afresh every time they
    # cost about 50,000 minor page faults; kept in the heap, only the first
    # one faults its pages in. 10,000 leaves room for other allocations.
    assert keep_freed_memory()
    np.ones(500_000).sum()
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(50):
        np.ones(500_000).sum()
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    assert faults < 10_000
