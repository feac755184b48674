"""The finish's shortcuts (subproblems/fast_finish.h, docs/design.md section 14, session 18) against the
code they stand in for, in C, on the values where they could part: both must decide alike bit for bit.

* ``ikc_fmod_two_pi`` (x itself below 2 pi, x -+ 2 pi between 2 pi and 4 pi) against libm's ``fmod``,
  on the ends (+-2 pi, +-4 pi and their neighbours, zeros of both signs, infinities, NaN) and on random
  values in (-20, 20); a difference in the sign of a zero counts.
* ``ikc_row6_kept`` (a 6-joint row ikc_represent would leave as it is) against ``ikc_represent`` itself:
  a row it passes holds no NaN and represent returns IKC_INSIDE with every value unchanged bit for bit,
  on rows drawn from the edge values (-pi + PI_SNAP and its neighbours, +-pi, the limits and their
  neighbours, 2 pi aliases, NaN), revolute and prismatic joints, limits on and off.  A row it does not
  pass takes represent itself, so a miss costs time only (represent also keeps, for instance, a value
  above pi whose wrapped value lies outside the limits and whose alias back is the value itself); that
  the shortcut is taken at all is held by the share of rows passed.

A small C program is compiled here from the finish library's own source (native._finish_library_source)
with the machine's flags, so the AVX2 lanes are the ones tested where the batch uses them.
"""

from __future__ import annotations

import subprocess

import pytest

from subproblems import native

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler")

CHECKS = r"""
#include <stdio.h>
#include <string.h>

static int same_bits(double a, double b) { return memcmp(&a, &b, sizeof a) == 0 || (a != a && b != b); }

static uint64_t state = 88172645463325252ull;
static uint64_t next(void) { state ^= state << 13; state ^= state >> 7; state ^= state << 17; return state; }
static double uniform(void) { return (next() >> 11) * (1.0 / 9007199254740992.0); }

int main(void) {
    long bad_fmod = 0, bad_kept = 0, kept = 0, rows = 0;
    const double ends[] = {IKC_TWO_PI, -IKC_TWO_PI, 2 * IKC_TWO_PI, -2 * IKC_TWO_PI, 0.0, -0.0, IKC_PI_F,
                           -IKC_PI_F, INFINITY, -INFINITY, NAN};
    for (int i = 0; i < (int)(sizeof ends / sizeof ends[0]); i++) {
        double x = ends[i], y = ends[i];
        for (int s = 0; s < 4; s++, x = nextafter(x, INFINITY), y = nextafter(y, -INFINITY)) {
            bad_fmod += !same_bits(ikc_fmod_two_pi(x), fmod(x, IKC_TWO_PI));
            bad_fmod += !same_bits(ikc_fmod_two_pi(y), fmod(y, IKC_TWO_PI));
        }
    }
    for (int i = 0; i < 2000000; i++) {
        const double x = (2.0 * uniform() - 1.0) * 20.0;
        bad_fmod += !same_bits(ikc_fmod_two_pi(x), fmod(x, IKC_TWO_PI));
    }
    const double snap = -IKC_PI_F + IKC_PI_SNAP;
    const double lo_ends[] = {-IKC_PI_F, -2.0, -IKC_TWO_PI, -0.5};
    const double hi_ends[] = {IKC_PI_F, 2.5, IKC_TWO_PI, 0.5};
    for (int trial = 0; trial < 200000; trial++) {
        int revolute[6];
        double lower[6], upper[6], x[6];
        for (int j = 0; j < 6; j++) {
            revolute[j] = next() % 5 != 0;
            lower[j] = lo_ends[next() % 4];
            upper[j] = hi_ends[next() % 4];
            const double lo = lower[j], hi = upper[j];
            const double pick[] = {snap, nextafter(snap, 0.0), nextafter(snap, -4.0), -IKC_PI_F, IKC_PI_F,
                                   nextafter(IKC_PI_F, 4.0), nextafter(IKC_PI_F, 0.0), lo, hi,
                                   nextafter(lo, -8.0), nextafter(hi, 8.0), lo - 5e-8, hi + 5e-8,
                                   2.0 * uniform() - 1.0, 3.0 + uniform(), -3.0 - uniform(),
                                   (2.0 * uniform() - 1.0) * 9.0, NAN, 0.0, -0.0};
            x[j] = next() % 3 ? (2.0 * uniform() - 1.0) * 3.0 : pick[next() % (sizeof pick / sizeof pick[0])];
        }
        ikc_robot rb;
        memset(&rb, 0, sizeof rb);
        rb.dof = 6, rb.revolute = revolute, rb.lower = lower, rb.upper = upper;
        ikc_b4 rev6[2] = {{-(int64_t)revolute[0], -(int64_t)revolute[1], -(int64_t)revolute[2],
                           -(int64_t)revolute[3]}, {-(int64_t)revolute[4], -(int64_t)revolute[5], 0, 0}};
        const ikc_row6 lo6 = ikc_row6_load(lower), hi6 = ikc_row6_load(upper);
        for (int limits = 0; limits < 2; limits++) {
            double w[6];
            int nan = 0, unchanged = 1, held[6];
            memcpy(w, x, sizeof w);
            for (int j = 0; j < 6; j++) nan |= x[j] != x[j];
            const int status = ikc_represent(&rb, w, limits, held);
            for (int j = 0; j < 6; j++) unchanged &= memcmp(&w[j], &x[j], sizeof w[j]) == 0;
            const int expect = !nan && status == IKC_INSIDE && unchanged;
            const int got = ikc_row6_kept(ikc_row6_load(x), rev6, &lo6, &hi6, limits);
            bad_kept += got && !expect;
            kept += got;
            rows++;
        }
    }
    printf("%ld %ld %ld %ld\n", bad_fmod, bad_kept, kept, rows);
    return 0;
}
"""


def test_the_finish_shortcuts_decide_as_the_code_they_stand_in_for(tmp_path):
    source = tmp_path / "checks.c"
    source.write_text(native._finish_library_source() + CHECKS)
    exe = tmp_path / "checks"
    flags = ["-O1", "-std=c99", "-ffp-contract=off", "-fno-math-errno", "-pthread", *native.machine_flags()]
    subprocess.run([native.compiler(), *flags, "-o", str(exe), str(source), "-lm"], check=True,
                   capture_output=True)
    bad_fmod, bad_kept, kept, rows = map(int, subprocess.run([str(exe)], capture_output=True, text=True,
                                                             check=True).stdout.split())
    assert bad_fmod == 0
    assert bad_kept == 0
    assert 0.05 * rows < kept < 0.95 * rows, (kept, rows)  # both verdicts are exercised
