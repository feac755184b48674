"""The POE chain model: FK against direct products, Jacobians against finite differences, inversion."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ikcompiler.errors import RobotInputError
from ikcompiler.model import Chain, Coupling, Joint
from subproblems.screw import inverse_transform, prismatic_twist, revolute_twist, twist_exp


def random_chain(rng, kinds: str, couple: bool = False) -> Chain:
    joints = []
    for i, k in enumerate(kinds):
        axis = rng.normal(size=3)
        if k == "R":
            tw = revolute_twist(axis, rng.normal(size=3))
        else:
            tw = prismatic_twist(axis)
        joints.append(Joint(f"j{i + 1}", k, tw, -3.0, 3.0))
    home = twist_exp(revolute_twist(rng.normal(size=3), rng.normal(size=3)), rng.uniform(-3, 3))
    home[:3, 3] += rng.normal(size=3)
    couplings = (Coupling("j3", "j2", 1.5, 0.2),) if couple else ()
    return Chain("random", tuple(joints), home, couplings)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["RRRRRR", "TRRRRR", "RTRTRT", "RRTR", "RRRRRRR"]))
def test_fk_equals_direct_product_and_batch(seed, kinds):
    rng = np.random.default_rng(seed)
    chain = random_chain(rng, kinds)
    Q = rng.uniform(-3, 3, size=(5, chain.dof))
    batch = chain.fk_batch(Q)
    for q, gb in zip(Q, batch):
        g = np.eye(4)
        for j, t in zip(chain.joints, q):
            g = g @ twist_exp(j.twist, t)
        g = g @ chain.home
        assert np.allclose(chain.fk(q), g, atol=1e-12)
        assert np.allclose(gb, g, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans())
def test_jacobians_match_finite_differences(seed, couple):
    rng = np.random.default_rng(seed)
    chain = random_chain(rng, "RTRRTR", couple=couple)
    q = rng.uniform(-2, 2, size=chain.dof)
    g = chain.fk(q)
    Js, Jb = chain.space_jacobian(q), chain.body_jacobian(q)
    h = 1e-6
    for i in range(chain.dof):
        dq = np.zeros(chain.dof)
        dq[i] = h
        dg = (chain.fk(q + dq) - chain.fk(q - dq)) / (2 * h)
        Vs = dg @ inverse_transform(g)  # space twist, hat form
        Vb = inverse_transform(g) @ dg  # body twist, hat form
        for V, J in ((Vs, Js), (Vb, Jb)):
            twist = np.concatenate([V[:3, 3], [V[2, 1], V[0, 2], V[1, 0]]])
            assert np.allclose(twist, J[:, i], atol=1e-6)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_inverted_chain_gives_inverse_pose(seed):
    rng = np.random.default_rng(seed)
    chain = random_chain(rng, "RRTRRR", couple=True)
    inv = chain.inverted()
    q = rng.uniform(-3, 3, size=chain.dof)
    # the inverted chain lists joints reversed: reverse the independent values to match
    names = chain.independent_names
    q_inv = np.array([q[names.index(n)] for n in inv.independent_names])
    assert np.allclose(inv.fk(q_inv) @ chain.fk(q), np.eye(4), atol=1e-10)


def test_coupling_follows_master():
    rng = np.random.default_rng(1)
    chain = random_chain(rng, "RRRR", couple=True)
    full = chain.expand([0.1, 0.2, 0.3])
    assert chain.independent_names == ("j1", "j2", "j4")
    assert np.allclose(full, [0.1, 0.2, 1.5 * 0.2 + 0.2, 0.3])


def test_bad_model_inputs_raise_named_errors():
    with pytest.raises(RobotInputError, match="joint 'a'"):
        Joint("a", "R", [0, 0, 0, 0, 0, 2])
    with pytest.raises(RobotInputError, match="kind"):
        Joint("a", "P", [0, 0, 0, 0, 0, 1])
    j = Joint("a", "R", revolute_twist([0, 0, 1], [0, 0, 0]))
    with pytest.raises(RobotInputError, match="'zz'"):
        Chain("c", (j,), np.eye(4), (Coupling("a", "zz"),))
    with pytest.raises(RobotInputError, match="duplicate"):
        Chain("c", (j, j), np.eye(4))
