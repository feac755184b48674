"""Near-degenerate pair instances (audit family ``near``) that a solver defect, not the data, lost.

Each was answered wrongly before (see its note) although its drawn values are a root of the float data
to ~1e-10 (checked at 40 digits).  The right-hand sides are evaluated here from the drawn values.
"""

from __future__ import annotations

import numpy as np
import pytest

from subproblems import solve
from subproblems._class3_pairs import Pair
from subproblems.screw import prismatic_twist, revolute_twist
from tests.strategies import contains_solution

from ._checks3 import check_instance, fk_point

_NEAR = {
    # axes anti-parallel and 1e-7 apart: the eliminant at 1.8e-13 of its terms was taken for identically
    # zero, no start reached an exact point, and the answer was ls (false-ls)
    "S3-RR near 99": {
        "tw": [
            [
                3.474265376201e-05,
                0.0005793114193312737,
                0.0003916206707369154,
                -0.8264532620133606,
                0.34848851565913724,
                -0.4421886024776835,
            ],
            [
                -3.474220030748199e-05,
                -0.0005793105417970573,
                -0.0003916208266621856,
                0.8264532620133606,
                -0.34848851565913724,
                0.4421886024776835,
            ],
        ],
        "th": [1.501340154500273, 1.6542575755181828],
        "p": [
            [-0.0005385793380146286, -0.0010334076037201681, -0.0012663779012997661],
            [0.0002150251341061602, 0.0007898771564424774, -0.0006458791607450808],
        ],
        "r": [[-0.0004023962162704099, -0.0009802250435971055, -0.0014789918701665417], [0.0, 0.0, 0.0]],
    },
    # prismatic directions anti-parallel to 1e-8: eliminant at 1e-17 of its terms, answered ls (false-ls)
    "S3-TT near 28": {
        "tw": [
            [0.4657662239690284, -0.8136055778123417, -0.34800544300668423, 0.0, 0.0, 0.0],
            [-0.46576623049360655, 0.8136055719981735, 0.34800544786727355, 0.0, 0.0, 0.0],
        ],
        "th": [-0.000699173570250939, -0.0005825360001987084],
        "p": [
            [0.0007599769507277054, 0.0008682656719793025, -0.0009512368739801911],
            [-0.0009192490562495016, -0.0011826565580576314, 0.0013172551887452974],
        ],
        "r": [[0.0, 0.0, 0.0], [-0.0009735748930248504, -0.0010877595770936966, 0.001357845695151079]],
    },
    # eliminant at 2.5e-12 of its terms, answered ls (false-ls)
    "H-RR near 75": {
        "tw": [
            [
                0.27410375361645195,
                0.44398651603991734,
                -0.44960551479071753,
                0.805412643120116,
                0.09518782163496024,
                0.5850211559547738,
            ],
            [
                -0.6321210579251935,
                0.20472278048041487,
                -0.300758255730174,
                0.4975751208338084,
                0.4277449565718935,
                -0.7546212634524222,
            ],
        ],
        "th": [-2.947589744238376, 1.8670011558055348],
        "p": [
            [-1.1225497380403557, 0.9168801368507129, 0.7071151253499983],
            [-0.062333811624392776, 0.5508630871862539, 0.5059765587111253],
        ],
        "r": [
            [0.5752010833768662, 1.6407421406559306, 0.9884882101258841],
            [0.7404110284911901, -1.419575871964083, 1.1985807660003691],
        ],
    },
    # two distinct roots ~1e-6 apart merged into one row 5e-7 from either (the merge's roundoff floor
    # was 10x too loose)
    "H-RR near 87": {
        "tw": [
            [
                0.233915744964861,
                0.8086932897677501,
                -0.48454570091836874,
                0.051789513919077386,
                -0.5242635516109756,
                -0.849979749582466,
            ],
            [
                0.40938288391347455,
                -0.4367144847709584,
                -0.7801351675050998,
                0.1036860021511393,
                -0.843699300033007,
                0.5267074179102931,
            ],
        ],
        "th": [-1.5707963267948966, 1.5707963267948966],
        "p": [
            [0.11964255080628483, -0.8527567505215204, -1.0677179416678158],
            [0.896628279930382, 0.2795194106252104, 0.8993598394598845],
        ],
        "r": [
            [-1.779448701292331, 0.3160453506204766, 0.8565498560038498],
            [0.1036860021511393, -0.843699300033007, 0.5267074179102931],
        ],
    },
    # scale 1e3, axes parallel and 5.5e-7 apart, d_1 = 0: answered ls (false-ls)
    "S3-RR near 48": {
        "tw": [
            [
                -189.10771780908797,
                707.5942443717496,
                41.11666449024195,
                -0.293690418789743,
                -0.02296092883815273,
                -0.9556247870675995,
            ],
            [
                -189.10678208460428,
                707.5944417801581,
                41.1163721725879,
                -0.293690418789743,
                -0.02296092883815273,
                -0.9556247870675995,
            ],
        ],
        "th": [-1.7631075578907676, -2.4134442910670817],
        "p": [[189.01699827357146, 154.77650992656814, -1794.287723870492], [0.0, 0.0, 0.0]],
        "r": [
            [-542.7608588093419, -184.3616770291967, -372.3469151181935],
            [857.4062339644456, 899.6424289223648, -285.12092340374755],
        ],
    },
}


@pytest.mark.parametrize("name", list(_NEAR))
def test_near_degenerate_pair(name):
    code = name.split()[0]
    case = _NEAR[name]
    tw, P, R = np.array(case["tw"]), np.array(case["p"]), np.array(case["r"])
    X = [fk_point(tw, case["th"], P[k]) for k in range(2)]
    if code.startswith("S3"):
        inputs = {"p": P, "q": R, "d": np.array([np.linalg.norm(X[k] - R[k]) for k in range(2)])}
    else:
        inputs = {"p": P, "h": R, "d": np.array([R[k] @ X[k] for k in range(2)])}
    r = check_instance(code, code.split("-")[1], tw, inputs, case["th"])
    assert not r.ls.any(), r


def test_least_squares_answer_is_converged():
    # unreachable H-RR (audit seed 2, general #69): Levenberg-Marquardt's 40 iterations left the ls
    # answer ~4e-6 from the minimiser in a flat valley, and solve_batch over 150 instances returned
    # another point than solve (roundoff differs between batch sizes); now the gradient J^T r vanishes
    # to ~1e-8 of |J| |r|
    tw = np.array(
        [
            [
                -0.38898922201269215,
                0.43535545032747675,
                0.12430609802164103,
                0.6684432466827264,
                0.68198951467874,
            ]
            + [-0.2967725186612002],
            [0.7048466798032198, -0.7633771817420266, -0.05938971719791558, -0.6978689694459829]
            + [-0.6159228275627644, -0.36553792138640173],
        ]
    )
    P = np.array([[0.4027422888367955, 0.22494044308018535, 0.472489786478332]] * 2)
    H = np.array(
        [
            [1.572959276228471, -1.2123369056708069, -0.23672419072696668],
            [-0.6978689694459829, -0.6159228275627644, -0.36553792138640173],
        ]
    )
    D = np.array([8.051650294647441, 6.1814146453657655])
    r = solve("H-RR", tw, p=P, h=H, d=D)
    assert r.ls.all() and len(r.q) == 1, r
    pb = Pair("H", "RR", tw[None], P[None], H[None], D[None])
    res, J = pb.residual(r.q[:, 0][None], r.q[:, 1][None])
    grad = np.einsum("...ki,...k->...i", J, res)
    assert np.abs(grad).max() <= 1e-7 * np.abs(J).max() * np.abs(res).max(), (r, grad)


# zero distances (q_k = g p_k): the equation is a cone in the joint values, solved as the class II
# coincidence; before, S3-RR came back 2e-8 off (the other equation tangent at the apex) and S3-TR
# (both equations the same coincidence, a point at scale 1e3) was answered ls
_COINCIDENCE = {
    "S3-RR": {
        "tw": [
            [0.0, 0.0, -1.0, 0.0, 1.0, 0.0],
            [-1.0606601717798212, 0.7071067811865475, -0.7071067811865475, 0.0, 0.7071067811865475]
            + [0.7071067811865475],
        ],
        "th": [0.8061564138636679, 0.0],
        "p": [[-1.0, 0.5, 0.5], [-1.0, 0.5, 0.5]],
        "q2": [1.0, 0.5, -0.5],
    },
    "S3-TR": {
        "tw": [
            [-0.5282592168837573, -0.8185609381108798, 0.22561070536744393, 0.0, 0.0, 0.0],
            [25.735413072035243, 46.24610974199211, 275.15408497407964, 0.5390453980832163]
            + [-0.8374189250290129, 0.09033051980675828],
        ],
        "th": [-587.2489296826973, 0.6406550215026994],
        "p": [[-926.0776286312417, 586.4792571847919, -44.89559952140265]] * 2,
        "q2": None,
    },
}


@pytest.mark.parametrize("code", list(_COINCIDENCE))
@pytest.mark.parametrize("d0", [0.0, 1e-16])
def test_zero_distance_is_a_point_coincidence(code, d0):
    case = _COINCIDENCE[code]
    tw, P, th = np.array(case["tw"]), np.array(case["p"]), case["th"]
    q1 = fk_point(tw, th, P[0])
    Q = np.array([q1, q1 if case["q2"] is None else case["q2"]])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    D[0] += d0 * np.abs(Q).max()  # a roundoff-sized distance (another forward kinematics) is the same
    r = check_instance(code, code.split("-")[1], tw, {"p": P, "q": Q, "d": D}, th)
    assert not r.ls.any() and not r.continuum, r
    assert contains_solution(r.q, th, code.split("-")[1], 1e-12), (r.q, th)


def test_weakly_determined_value_from_a_multiple_root():
    # thorough profile: p_1 = q_1 = the origin (on axis 1, d_1 = 0) makes the eliminant's root at
    # th_2 = 0 a cluster of six, spread 4e-3; p_2 is 1e-8 from axis 1, so th_1 moves equation 2 by 1e-8
    # per radian, back-substitution put it anywhere and polishing stalled at an extremum of equation 2:
    # the root th_1 = 0 was lost (the other, -1.70, came back).  Stalled near misses now start again
    # from equation 2 solved for th_1 at the polished th_2
    tw = np.array(
        [revolute_twist([5.0, 1.0, 2.0], [0.0, 0.0, 0.0]), revolute_twist([1.0, 0.0, 0.0], [0, 0, 1.0])]
    )
    th = np.array([0.0, 0.0])
    P, Q = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1e-8]]), np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance("S3-RR", "RR", tw, {"p": P, "q": Q, "d": D}, th)
    assert len(r.q) == 2 and not r.ls.any() and not r.continuum, r
    # th_1 = 0 is fixed by equation 2 only to ~eps / 6e-9 ~ 3e-8
    assert contains_solution(r.q, th, "RR", 1e-7) and contains_solution(r.q, [-1.7023975858, 0.0], "RR", 1e-7)


@pytest.mark.parametrize("tiny", [2.5e-213, 1e-300])
def test_lengths_that_square_to_zero(tiny):
    # thorough profile: a point (0, -1e-308, 2.5e-213): its length squared underflows, the scale came
    # out as 0 and the normalised instance had entries ~1e175 (LinAlgError from the eigenvalues)
    tw = np.array([[1.0, 0, 0, 0, 0, 0], [0.91287093, 0.18257419, 0.36514837, 0, 0, 0]])
    P = np.array([[0.0, -1.11253693e-308, tiny], [0.0, 0.0, 0.0]])
    Q, th = np.zeros((2, 3)), np.array([0.0, 0.0])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    check_instance("S3-TT", "TT", tw, {"p": P, "q": Q, "d": D}, th)


def test_root_where_one_equation_barely_depends_on_the_eliminated_value():
    # thorough profile: p_1 at the origin, on axis 1, axes 0.0039 rad from parallel.  At th_2 = 0
    # equation 1 does not depend on th_1; the eliminant's double root there came back as a complex
    # pair 3e-5 off the circle, and Cramer's th_1 (following equation 1's vanishing row) was -1.57:
    # the well-conditioned root (0, 0) (sigma_min 1.6e-3) was lost.  Now the other equation alone also
    # gives th_1 there
    w = np.array([0.99999237, 0.00390622, 0.0])
    tw = np.array([revolute_twist(w, [0.0, 0.0, 0.0]), revolute_twist([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])])
    th = np.array([0.0, 0.0])
    P, Q = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5]]), np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance("S3-RR", "RR", tw, {"p": P, "q": Q, "d": D}, th)
    assert not r.ls.any() and contains_solution(r.q, th, "RR", 1e-12), r


def test_tangent_point_represents_its_cluster():
    # thorough profile: p_1 at the origin (d_1 = 0, th_1 = 0 forced), p_2 1e-5 from axis 2: equation 2
    # is tangent at th_2 = 0 (residual 2.6e-6 th_2^2, Jacobian zero there).  The tangent point was
    # found, but the cluster merge kept a member 7.5e-6 away (the same residual, 0) in its place
    w = np.array([0.0, 1.0, 1e-5])
    tw = np.array([prismatic_twist([1.0, 0.0, 0.0]), revolute_twist(w, [0.0, 0.0, 0.0])])
    th = np.array([0.0, 0.0])
    P, Q = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.625]])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance("S3-TR", "TR", tw, {"p": P, "q": Q, "d": D}, th)
    assert not r.ls.any() and contains_solution(r.q, th, "TR", 1e-12), r


def test_root_at_the_centre_of_a_cluster():
    # thorough profile: as above with the axes 6.1e-5 rad from parallel and p_2 = (0, 0, 1): the root of
    # the eliminant at th_2 = 0 came back as a cluster of four spread 8e-4, where th_1 (acting 6e-5
    # per radian) was found at +-pi/2 from every member; the cluster's centre gives (0, 0)
    w = np.array([0.999999998, 6.10351561e-05, 0.0])
    tw = np.array([revolute_twist(w, [0.0, 0.0, 0.0]), revolute_twist([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])])
    th = np.array([0.0, 0.0])
    P, Q = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    D = np.array([np.linalg.norm(fk_point(tw, th, P[k]) - Q[k]) for k in range(2)])
    r = check_instance("S3-RR", "RR", tw, {"p": P, "q": Q, "d": D}, th)
    assert not r.ls.any() and contains_solution(r.q, th, "RR", 1e-9), r
