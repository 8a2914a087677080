"""The arithmetic floor of each model's likelihood: the fewest-operation numpy evaluation we know.

For a batch of parameter vectors ``(W, k + 2)`` (model parameters, ``sigma_rel``, ``sigma_abs``) at
fixed frequencies, each floor computes the same Gaussian total log-likelihood as
:class:`bayes_emt.inference.likelihood.Likelihood` (checked against it to 1e-9 by
``bench_likelihood``), written out by hand for that one model: polynomial coefficients expanded
on paper, the measured data folded into the real matrix basis, the Bessel ratio by the same table
lookup inlined, the noise sums as power series, walkers in cache-sized chunks with preallocated
buffers. No priors, transforms, term bookkeeping, checks or NaN handling: what remains is
arithmetic. The package's fraction of this speed (``floor_fraction``) is the price of its
generality.
"""

from __future__ import annotations

import math

import numpy as np

from bayes_emt.models import terms as T

J = 5  # series terms of the noise sums (bayes_emt.inference.noise: SERIES_TERMS + 1)


class Floors:
    """Floors for one measurement ``(omega [rad/s], Y [S])``, unit weights, ``n_turns`` turns."""

    def __init__(self, omega, Y, n_turns=480.0, rings=5, max_degree=8):
        self.omega, self.Y = np.asarray(omega, float), np.asarray(Y, complex)
        self.F = self.omega.size
        self.N2 = float(n_turns) ** 2
        self.rings = rings
        a = 1.0 / np.abs(self.Y) ** 2
        self.a, self.amax, self.amin = a, a.max(), a.min()
        self.c = np.sqrt(a)
        self.const = -self.F * math.log(2 * math.pi) - float(np.sum(np.log(1 / a)))
        j = np.arange(J)
        self.P_low = np.ascontiguousarray(a[:, None] ** j)
        self.P_high = np.ascontiguousarray(a[:, None] ** -(j + 1.0))
        self.l_low = np.array([(-1.0) ** (i + 1) / i * np.sum(a**i) for i in range(1, J)])
        self.l_high = np.array([(-1.0) ** (i + 1) / i * np.sum(a**-i) for i in range(1, J)])
        self.sum_log_a = float(np.sum(np.log(a)))
        k = np.arange(max_degree + 1)
        sign = np.where((k // 2) % 2 == 0, 1.0, -1.0)
        self.B = sign[:, None] * self.omega[None, :] ** k[:, None]  # Re or Im of (jω)^k
        yr, yi = self.Y.real * self.c, self.Y.imag * self.c
        self.yr, self.yi = yr, yi
        # folded rows: (jω)^k c for D, and -c Y (jω)^k for N, stacked [real | imag]
        F = self.F
        self.Dfold = np.zeros((max_degree + 1, 2 * F))
        self.Nfold = np.zeros((max_degree + 1, 2 * F))
        self.Nplain = np.zeros((max_degree + 1, 2 * F))
        for kk in range(max_degree + 1):
            p = self.B[kk]
            if kk % 2 == 0:
                self.Dfold[kk, :F] = p * self.c
                self.Nfold[kk, :F], self.Nfold[kk, F:] = -yr * p, -yi * p
                self.Nplain[kk, :F] = p
            else:
                self.Dfold[kk, F:] = p * self.c
                self.Nfold[kk, :F], self.Nfold[kk, F:] = yi * p, -yr * p
                self.Nplain[kk, F:] = p
        self.hlw = 0.5 * np.log(self.omega) / T._TABLE_STEP
        self.tab = T._h_table()
        self.Be, self.Bo = np.ascontiguousarray(self.B[0::2]), np.ascontiguousarray(self.B[1::2])
        self.chunk = max(1, (1 << 18) // (16 * self.F))
        self._bufs = {}

    # ---- pieces -------------------------------------------------------------------------------
    def _noise(self, e, srel, sabs):
        rho2 = (sabs / srel) ** 2
        j = np.arange(J)
        if np.all(rho2 * self.amax <= 1e-3):
            S = np.sum((e @ self.P_low) * (-rho2[:, None]) ** j, axis=1)
            L = (rho2[:, None] ** j[1:]) @ self.l_low
        elif np.all(rho2 * self.amin >= 1e3):
            inv = 1.0 / rho2
            S = np.sum((e @ self.P_high) * (-inv[:, None]) ** j, axis=1) * inv
            L = self.F * np.log(rho2) + self.sum_log_a + (inv[:, None] ** j[1:]) @ self.l_high
        else:
            x = rho2[:, None] * self.a
            S = np.sum(e / (1 + x), axis=1)
            L = np.sum(np.log1p(x), axis=1)
        return self.const - 2 * self.F * np.log(srel) - L - S / (2 * srel * srel)

    def _buf(self, name, shape, dtype=float):
        a = self._bufs.get(name)
        if a is None or a.shape != shape or a.dtype != np.dtype(dtype):
            a = self._bufs[name] = np.empty(shape, dtype)
        return a

    def _rational_e(self, num, den):
        return self._bessel_e(num, den, None, None)

    def _bessel_e(self, num, den, alpha, beta):
        W, F, c = num.shape[0], self.F, self.chunk
        e = self._buf("e", (W, F))
        cat = np.ascontiguousarray(np.hstack([den, num]))
        M = np.vstack([self.Dfold[: den.shape[1]], self.Nfold[: num.shape[1]]])
        ne, no = (num.shape[1] + 1) // 2, num.shape[1] // 2
        nume, numo = np.ascontiguousarray(num[:, 0::2]), np.ascontiguousarray(num[:, 1::2])
        if alpha is not None:
            p0 = (0.5 * np.log(alpha) - T._TABLE_T[0]) / T._TABLE_STEP
            gd = (beta / np.sqrt(alpha))[:, None] * den
            gde, gdo = np.ascontiguousarray(gd[:, 0::2]), np.ascontiguousarray(gd[:, 1::2])
            de, do = (den.shape[1] + 1) // 2, den.shape[1] // 2
        E = self._buf("E", (c, 2 * F))
        Tn = self._buf("T", (c, 2 * F))
        D = self._buf("D", (c, 2 * F))
        pos, fr, hr, hi, tmp, bdr, bdi = (self._buf(k, (c, F)) for k in ("pos", "fr", "hr", "hi", "tmp",
                                                                        "bdr", "bdi"))
        idx = self._buf("idx", (c, F), np.intp)
        t = self.tab
        for a in range(0, W, c):
            b = min(a + c, W)
            n = b - a
            En, Tk = E[:n], Tn[:n]
            np.matmul(cat[a:b], M, out=En)
            np.matmul(nume[a:b], self.Be[:ne], out=Tk[:, :F])
            np.matmul(numo[a:b], self.Bo[:no], out=Tk[:, F:])
            if alpha is not None:
                Dk, ps, f, h1, h2, tp, b1, b2, ix = (D[:n], pos[:n], fr[:n], hr[:n], hi[:n], tmp[:n],
                                                     bdr[:n], bdi[:n], idx[:n])
                np.matmul(gde[a:b], self.Be[:de], out=Dk[:, :F])
                np.matmul(gdo[a:b], self.Bo[:do], out=Dk[:, F:])
                np.add(p0[a:b, None], self.hlw, out=ps)
                np.copyto(ix, ps, casting="unsafe")
                np.subtract(ps, ix, out=f)
                for acc, (c0, c1, c2, c3) in ((h1, t[:4]), (h2, t[4:])):
                    np.take(c3, ix, out=acc, mode="clip")
                    for cc in (c2, c1, c0):
                        acc *= f
                        acc += np.take(cc, ix, out=tp, mode="clip")
                dr, di = Dk[:, :F], Dk[:, F:]
                np.multiply(h1, dr, out=b1)
                b1 -= np.multiply(h2, di, out=tp)
                np.multiply(h1, di, out=b2)
                b2 += np.multiply(h2, dr, out=tp)
                Tk[:, :F] += b1
                Tk[:, F:] += b2
                En[:, :F] -= np.multiply(b1, self.yr, out=tp)
                En[:, :F] += np.multiply(b2, self.yi, out=tp)
                En[:, F:] -= np.multiply(b2, self.yr, out=tp)
                En[:, F:] -= np.multiply(b1, self.yi, out=tp)
            np.square(En, out=En)
            np.square(Tk, out=Tk)
            np.add(En[:, :F], En[:, F:], out=e[a:b])
            np.add(Tk[:, :F], Tk[:, F:], out=Tk[:, :F])
            np.divide(e[a:b], Tk[:, :F], out=e[a:b])
        return e

    @staticmethod
    def _mech(z, w0):
        return np.stack([w0 * w0, 2 * z * w0, np.ones_like(w0)], axis=1)

    def _ladder(self, Pg, P, R):
        W, n = P.shape
        a = np.zeros((W, n + 1))
        b = np.zeros((W, n + 1))
        b[:, 0] = 1.0
        for j in range(n):
            c = a[:, : j + 1] + P[:, j, None] * b[:, : j + 1]
            a[:, : j + 1] = c
            b[:, 1 : j + 2] += c / R[:, j, None]
        num = np.zeros((W, n + 2))
        num[:, 1:] = self.N2 * (Pg[:, None] * b + a)
        return num, b

    @staticmethod
    def _mul(p, q):
        out = np.zeros((p.shape[0], p.shape[1] + q.shape[1] - 1))
        for i in range(p.shape[1]):
            out[:, i : i + q.shape[1]] += p[:, i, None] * q
        return out

    # ---- the floors -----------------------------------------------------------------------------
    def I(self, th):  # noqa: E743
        z, w0, ph, R0, L0, srel, sabs = th.T
        m = self._mech(z, w0)
        num = np.stack([R0 * m[:, 0], R0 * m[:, 1] + L0 * m[:, 0] + ph * ph, R0 + L0 * m[:, 1], L0], axis=1)
        return self._noise(self._rational_e(num, m), srel, sabs)

    def II(self, th):
        z, w0, ph, R0, L0, Rm, srel, sabs = th.T
        m = self._mech(z, w0)
        den = self._mul(m, np.stack([Rm, L0], axis=1))
        num = R0[:, None] * den
        num[:, 1:] += (Rm * L0)[:, None] * m
        num[:, 1] += ph * ph * Rm
        num[:, 2] += ph * ph * L0
        return self._noise(self._rational_e(num, den), srel, sabs)

    def III(self, th):
        z, w0, ph, R0, al, be, srel, sabs = th.T
        m = self._mech(z, w0)
        num = R0[:, None] * m
        num[:, 1] += ph * ph
        return self._noise(self._bessel_e(num, m, al, be), srel, sabs)

    def UD(self, th):
        z, w0, ph, R0, Lg, al, be, srel, sabs = th.T
        m = self._mech(z, w0)
        num = np.zeros((th.shape[0], 4))
        num[:, :3] = R0[:, None] * m
        num[:, 1:] += Lg[:, None] * m
        num[:, 1] += ph * ph
        return self._noise(self._bessel_e(num, m, al, be), srel, sabs)

    def _coil_rational(self, th, Pg, P, R):
        z, w0, ph, R0 = th[:, 0], th[:, 1], th[:, 2], th[:, 3]
        m = self._mech(z, w0)
        nc, dc = self._ladder(Pg, P, R)
        inner = nc.copy()
        inner[:, : dc.shape[1]] += R0[:, None] * dc
        num = self._mul(inner, m)
        num[:, 1 : dc.shape[1] + 1] += (ph * ph)[:, None] * dc
        return num, self._mul(dc, m)

    def NL(self, th):
        n = self.rings
        num, den = self._coil_rational(th, th[:, 4], th[:, 5 : 5 + n], th[:, 5 + n : 5 + 2 * n])
        return self._noise(self._rational_e(num, den), th[:, -2], th[:, -1])

    def UL(self, th):
        n, N2 = self.rings, self.N2
        Lg, al, be = th[:, 4], th[:, 5], th[:, 6]
        j = np.arange(1, n + 1, dtype=float)
        P = np.repeat((be * np.sqrt(al) / (2 * N2 * n))[:, None], n, axis=1)
        R = (be / (N2 * np.sqrt(al)))[:, None] * (np.sqrt(j) / (np.sqrt(j) - np.sqrt(j - 1)))
        num, den = self._coil_rational(th, Lg / N2, P, R)
        return self._noise(self._rational_e(num, den), th[:, -2], th[:, -1])
