"""Fast kernels on s = jω (models/terms.py): the Bessel table, the ring ladder as polynomials,
rational sums and their evaluation by matrix products — each against an independent reference."""

import numpy as np
import pytest
from scipy import special

from bayes_emt.models import terms as T
from bayes_emt.reference import PAPER_TABLES


def continued_fraction(w):
    """I1(w)/I0(w) = w/(2 + w²/(4 + w²/(6 + ...))), evaluated backwards to convergence (the
    recurrence of Abramowitz & Stegun 9.6.26; independent of scipy's Bessel routines), for
    |w| <= 2e3; beyond, where the package uses its asymptotic series, scipy's scaled ive ratio."""
    w = np.asarray(w, complex)
    out = np.empty_like(w)
    small = np.abs(w) <= 2e3
    ws = w[small]
    acc = np.zeros_like(ws)
    for k in range(int(2 * np.max(np.abs(ws), initial=0)) + 60, 0, -1):
        acc = ws * ws / (2.0 * k + acc)
    out[small] = acc / ws
    out[~small] = special.ive(1, w[~small]) / special.ive(0, w[~small])
    return out


def test_bessel_table_is_accurate_to_1e13_over_the_whole_range():
    # the table covers |w| = 1e-4..1e3 (cubic Hermite, step 2^-10 in ln|w|); outside it the exact
    # series take over. Reference: the continued fraction; tolerance 2e-13 relative (the table's
    # interpolation error is < 1e-13, the reference's rounding ~1e-15)
    u = np.geomspace(1e-6, 3e4, 1201)
    w = u * np.exp(0.25j * np.pi)
    ref = continued_fraction(w)
    got = T.bessel_ratio_jw(u**2, 1.0)  # alpha = u², omega = 1: |w| = u
    np.testing.assert_allclose(got, ref, rtol=2e-13)
    # the same through (alpha, omega) pairs of a sampler's range, broadcast (W, 1) x (F,)
    alpha = np.geomspace(1e-10, 1e2, 7)[:, None]
    omega = np.geomspace(1e-1, 1e7, 120)
    got = T.bessel_ratio_jw(alpha, omega)
    assert got.shape == (7, 120)
    np.testing.assert_allclose(got, continued_fraction(np.sqrt(1j * alpha * omega)), rtol=2e-13)


def test_bessel_table_is_finite_where_jv_overflows():
    # SPEC form -beta sqrt(-s) J1(sqrt(-alpha s))/J0(...): jv overflows once |Im z| ~ 700
    u = np.geomspace(2e3, 1e6, 50)
    z = u * np.exp(-0.25j * np.pi)
    with np.errstate(all="ignore"):
        assert not np.any(np.isfinite(special.jv(1, z) / special.jv(0, z)))
    got = T.bessel_ratio_jw(u**2, 1.0)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, continued_fraction(u * np.exp(0.25j * np.pi)), rtol=1e-14)


def test_bessel_eddy_jw_is_model_III_and_bessel_eddy_uses_it():
    omega = np.geomspace(1e-1, 1e7, 200)
    alpha, beta = np.array([[3.74e-4], [7e-5]]), np.array([[0.287], [0.529]])
    re, im = T.bessel_eddy_jw(omega, alpha, beta)
    ref = beta * np.sqrt(1j * omega) * continued_fraction(np.sqrt(alpha * 1j * omega))
    np.testing.assert_allclose(re + 1j * im, ref, rtol=2e-13)
    np.testing.assert_allclose(T.bessel_eddy(1j * omega, alpha, beta), ref, rtol=2e-13)
    # off the imaginary axis the exact ive path is kept (a pole-zero search may ask there)
    s = -3.0 + 1j * omega
    np.testing.assert_allclose(T.bessel_eddy(s, 3.74e-4, 0.287),
                               0.287 * np.sqrt(s) * continued_fraction(np.sqrt(3.74e-4 * s)), rtol=1e-12)


def test_bessel_into_handles_points_off_the_table_and_nan():
    pos = np.array([-5000.0, 10.5, 2e4, np.nan])  # |w| = 6e-7, inside, 3e4; NaN
    re, im, frac, tmp = (np.empty(4) for _ in range(4))
    T.bessel_h_into(pos.copy(), re, im, np.empty(4, np.intp), frac, tmp)
    t = pos * T._TABLE_STEP + T._TABLE_T[0]
    w = np.exp(t[:3]) * np.exp(0.25j * np.pi)
    np.testing.assert_allclose(re[:3] + 1j * im[:3], w * continued_fraction(w), rtol=2e-13)
    assert np.isnan(re[3]) and np.isnan(im[3])


def _eq41(s, Pg, Pv, Rv, N):
    """SPEC eq. (41) by dense linear algebra, one s at a time."""
    n = Pv.size
    D, U = np.tril(np.ones((n, n))), np.ones(n)
    Pm, Rm = np.diag(Pv), np.diag(Rv)
    return (N**2 * (Pg + U @ Pm @ U) * s
            - N**2 * (U @ Pm @ D.T @ np.linalg.solve(D @ Pm @ D.T * s + Rm, D @ Pm @ U)) * s**2)


def test_ladder_polynomials_equal_equation_41():
    p = PAPER_TABLES["NL"]
    Pv = np.array([p[f"P{j}"] for j in range(1, 6)])
    Rv = np.array([p[f"R{j}"] for j in range(1, 6)])
    num, den = T.ladder_polynomials(p["Pg"], Pv, Rv, 480.0)
    assert num.shape == (7,) and den.shape == (6,) and den[0] == 1.0
    assert np.all(num[1:] > 0) and np.all(den > 0)  # positive coefficients: no cancellation on jω
    s = 1j * np.geomspace(1, 1e6, 40)
    z = np.polynomial.polynomial.polyval(s, num) / np.polynomial.polynomial.polyval(s, den)
    np.testing.assert_allclose(z, [_eq41(si, p["Pg"], Pv, Rv, 480.0) for si in s], rtol=1e-10)


def test_ladder_polynomials_vectorise_and_flag_non_physical_sets():
    rng = np.random.default_rng(0)
    P = 4e-9 * 10 ** rng.uniform(-2, 2, (6, 3))
    R = 1e-5 * 10 ** rng.uniform(-2, 2, (6, 3))
    Pg = 3e-9 * np.ones(6)
    P[2, 1], R[4, 0] = -1e-9, 0.0
    num, den = T.ladder_polynomials(Pg, P, R, 480.0)
    assert num.shape == (6, 5) and den.shape == (6, 4)
    assert np.all(np.isnan(num[[2, 4]])) and np.all(np.isfinite(num[[0, 1, 3, 5]]))
    single = T.ladder_polynomials(Pg[0], P[0], R[0], 480.0)
    np.testing.assert_allclose(num[0], single[0], rtol=1e-15)


def test_ring_ladder_on_the_imaginary_axis_equals_the_modal_form():
    rng = np.random.default_rng(3)
    p = PAPER_TABLES["NL"]
    P = np.array([p[f"P{j}"] for j in range(1, 6)]) * 10 ** rng.uniform(-1, 1, (4, 5))
    R = np.array([p[f"R{j}"] for j in range(1, 6)]) * 10 ** rng.uniform(-1, 1, (4, 5))
    Pg = p["Pg"] * np.ones(4)
    s = 1j * np.geomspace(1e-1, 1e7, 300)
    gap, Lk, tau = T.ring_ladder_modes(Pg, P, R, 480.0)
    modal = gap[:, None] * s + np.sum(Lk[:, None, :] * s[:, None] / (1 + tau[:, None, :] * s[:, None]), -1)
    np.testing.assert_allclose(T.ring_ladder(s, Pg, P, R, 480.0), modal, rtol=1e-9)


def test_rational_sums_and_matrix_evaluation_on_jw():
    rng = np.random.default_rng(1)
    zeta, w0, phi, R0, L0, Rmu = 0.01, 50.8, 1.7, 2.57, 2e-3, 2.95
    pairs = [T.resistance_polynomials(R0), T.lossy_inductance_polynomials(L0, Rmu),
             T.motional_polynomials(zeta, w0, phi), T.inductance_polynomials(1e-4)]
    num, den = pairs[0]
    for pair in pairs[1:]:
        num, den = T.add_rational((num, den), pair)
    omega = np.geomspace(1, 1e5, 200)
    s = 1j * omega
    direct = R0 + Rmu * L0 * s / (Rmu + L0 * s) + phi**2 * s / (s * s + 2 * zeta * w0 * s + w0**2) + 1e-4 * s
    nr, ni = T.polynomial_jw(num, omega)
    dr, di = T.polynomial_jw(den, omega)
    np.testing.assert_allclose((nr + 1j * ni) / (dr + 1j * di), direct, rtol=1e-12)
    a, b = rng.standard_normal((3, 4)), rng.standard_normal((3, 2))
    prod = T.poly_mul(a, b)
    for i in range(3):
        np.testing.assert_allclose(prod[i], np.polynomial.polynomial.polymul(a[i], b[i]), rtol=1e-14)


@pytest.mark.parametrize("degree", [0, 1, 4, 7])
def test_jw_power_basis_is_the_real_and_imaginary_parts_of_powers(degree):
    omega = np.geomspace(0.5, 3e3, 9)
    even, odd = T.jw_power_basis(omega, degree)
    ref = (1j * omega)[None, :] ** np.arange(degree + 1)[:, None]
    np.testing.assert_allclose(even, ref[0::2].real, rtol=1e-15)
    np.testing.assert_allclose(odd, ref[1::2].imag, rtol=1e-15)
    assert np.all(ref[0::2].imag == 0) and np.all(ref[1::2].real == 0)


def test_every_term_kernel_on_jw_equals_its_evaluate():
    # the terms own their fast kernels (Term.jw_rational / jw_bessel): each one offered must be what
    # the term's evaluate gives on s = jω, at parameter sets spread over the whole prior
    from bayes_emt.models import TERMS

    omega = np.geomspace(1.0, 1e5, 120)
    s = 1j * omega
    offered = set()
    for term_id, cls in TERMS.items():
        term = cls.make()
        u = np.random.default_rng(len(term_id)).uniform(0.05, 0.95, (6, len(term.params)))
        v = term.params.prior_transform(u)
        pair, bessel = term.jw_rational(v), term.jw_bessel(v)
        assert pair is None or bessel is None, term_id
        if pair is None and bessel is None:
            continue
        assert not term.needs, term_id  # a kernel sees only the term's own parameters
        offered.add(term_id)
        ref = term.evaluate(s, v, {})
        if pair is not None:
            nr, ni = T.polynomial_jw(pair[0], omega)
            dr, di = T.polynomial_jw(pair[1], omega)
            got = (nr + 1j * ni) / (dr + 1j * di)
        else:
            br, bi = T.bessel_eddy_jw(omega, bessel[0][:, None], bessel[1][:, None])
            got = br + 1j * bi
        np.testing.assert_allclose(got, ref, rtol=1e-10, err_msg=term_id)
    # the paper's terms all have one; so do the rational augmentations
    assert offered == {"motional", "resistance", "inductance", "gap_inductance", "lossy_inductance",
                       "bessel_eddy", "ring_ladder", "uniform_rings", "winding_capacitance",
                       "second_resonance", "lr2", "lead_impedance"}
