"""Every code the issue and docs/design.md section 4 name has a registered solver."""

from subproblems import codes, max_solutions

KINDS_3 = ["R", "T", "RR", "RT", "TR", "TT", "RRR", "RRT", "TRR", "RTR", "TTR", "RTT", "TRT", "TTT"]
REQUIRED = (
    [f"S1-{k}" for k in KINDS_3]
    + [f"S2-{k}" for k in KINDS_3]
    + [f"S3-{k}" for k in ["R", "T", "RR", "RT", "TR", "TT"]]
    + ["O-R", "O-RR", "O-RRR", "H-R", "H-T"]
)


def test_all_28_types_and_the_extras_are_registered():
    have = set(codes())
    assert len({c for c in REQUIRED if c[:2] in ("S1", "S2", "S3")}) == 34  # 14 + 14 + 6 codes, 28 types
    assert sorted(set(REQUIRED) - have) == []
    assert all(max_solutions(c) >= 1 for c in REQUIRED)
