"""The likelihood's fast path: a model's admittance on the measured ``s = jω`` in real arithmetic.

A :class:`JwPlan` evaluates a batch of parameter sets ``(W, k)`` of a model at the measurement's
fixed frequencies from the model's :class:`~bayes_emt.models.model.JwForm`
(:meth:`Model.jw_form <bayes_emt.models.model.Model.jw_form>`), which the terms themselves provide
(:meth:`Term.jw_rational <bayes_emt.models.term.Term.jw_rational>`, :meth:`Term.jw_bessel
<bayes_emt.models.term.Term.jw_bessel>`); nothing here knows a term or a model by name:

* the rational terms (resistance, inductances, lossy inductance, motional branch, NL ring ladder,
  UL rings, and the augmentations with a rational form: another mode, LR-2, leads, winding
  capacitance) as one polynomial pair ``Zr = N(s)/D(s)``, whose real and imaginary parts at ``jω``
  are small real matrix products with a precomputed basis
  (:func:`~bayes_emt.models.terms.jw_power_basis`);
* plus the Bessel terms (models III, UD) from the 45° table (:func:`~bayes_emt.models.terms.bessel_eddy_jw`).

The quantity a Gaussian likelihood needs is the scaled squared residual
``e_k = |Y(jω_k) − Y_k|² c_k²`` with a fixed per-frequency scale ``c_k``. Writing the model
admittance as ``Y = D/T`` with ``T = N + B D`` (``B`` the Bessel part), ``Y − Y_k = E/T`` with
``E = D − Y_k T``; ``D − Y_k N`` is linear in the polynomial coefficients, so the measured data
and ``c_k`` are folded into the basis once and ``E`` costs one matrix product (plus ``B``'s terms).
No complex division, no complex temporaries, no per-term arrays. Parallel admittances (winding
capacitance) are folded into the pair by :meth:`Model.jw_form
<bayes_emt.models.model.Model.jw_form>` (then ``D/N`` is the whole admittance and ``B = 0``).

A plan is only used after it reproduced :meth:`Model.admittance` at three parameter sets to
1e-9 relative (:meth:`JwPlan.build`); a model with a term that offers no fast kernel (a creep,
port, drift, semi-inductance or instrument term; a parallel term beside a Bessel kernel), more
than :data:`MAX_DEGREE` polynomial degrees, or frequencies whose powers would overflow gets no
plan, and the likelihood evaluates it through the model instead.
"""

from __future__ import annotations

import threading

import numpy as np

from ..models import JwForm, Model
from ..models import terms as T

__all__ = ["JwPlan", "MAX_DEGREE"]

#: Highest polynomial degree evaluated in the monomial basis (NL/UL up to 12 rings with the motional
#: branch); beyond it the powers of ω span too many decades.
MAX_DEGREE = 16
_CHECK_RTOL = 1e-9
#: Bytes of one ``(rows, 2F)`` work array: walkers are processed in chunks whose working set stays
#: in the CPU's cache, in buffers reused from call to call (fresh multi-megabyte temporaries cost
#: page faults: 5x on the Bessel models on a loaded machine).
CHUNK_BYTES = 1 << 18


class _Workspace(threading.local):
    """Per-thread scratch arrays, reused while their shape fits."""

    def __init__(self):
        self.arrays = {}

    def get(self, name: str, shape: tuple, dtype=float) -> np.ndarray:
        a = self.arrays.get(name)
        if a is None or a.shape != shape or a.dtype != np.dtype(dtype):
            a = np.empty(shape, dtype)
            self.arrays[name] = a
        return a


class JwPlan:
    """Evaluation of one model at fixed angular frequencies ``omega`` [rad/s] (module docstring).

    Use :meth:`build` (returns ``None`` when the model has no fast path); the constructor raises
    ``NotImplementedError`` for an unsupported model.
    """

    def __init__(self, model: Model, omega):
        self.omega = np.asarray(omega, float)
        if self.omega.ndim != 1 or not np.all(self.omega > 0):
            raise NotImplementedError("the fast path needs positive angular frequencies")
        self.model, self.ndim = model, model.ndim
        probe = model.jw_form(np.ones((1, model.ndim)))
        if probe is None:
            raise NotImplementedError(f"model {model.label}: some term has no fast kernel on s = jω")
        self.n_bessel = len(probe.bessel)
        self.deg_num, self.deg_den = probe.num.shape[-1] - 1, probe.den.shape[-1] - 1
        if max(self.deg_num, self.deg_den) > MAX_DEGREE:
            raise NotImplementedError("polynomial degree too high for the monomial basis")
        deg = max(self.deg_num, self.deg_den)
        with np.errstate(over="ignore"):
            self._basis = T.jw_power_basis(self.omega, deg)
        if not all(np.all(np.isfinite(b)) & np.all(np.abs(b) < 1e250) for b in self._basis):
            raise NotImplementedError("powers of the frequencies overflow")
        self._half_log_omega = 0.5 * np.log(self.omega)
        self._pos_omega = T.table_position(0.0, self._half_log_omega) - T.table_position(0.0, 0.0)
        self._folded: dict = {}
        self._work = _Workspace()
        self.chunk = max(1, CHUNK_BYTES // (16 * self.omega.size))

    def __getstate__(self):
        state = dict(self.__dict__)
        state["_work"], state["_folded"] = None, {}
        return state

    def __setstate__(self, state):
        self.__dict__.update(state)
        self._work = _Workspace()

    @classmethod
    def build(cls, model: Model, omega) -> JwPlan | None:
        """A checked plan, or ``None`` if the model has none or it disagrees with the model."""
        try:
            plan = cls(model, omega)
        except NotImplementedError:
            return None
        u = np.array([[0.3], [0.5], [0.7]]) + np.linspace(-0.05, 0.05, model.ndim)[None, :]
        theta = model.params.prior_transform(u)
        with np.errstate(all="ignore"):
            ref = model.admittance(plan.omega, theta)
            got = plan.admittance(theta)
        ok = np.isfinite(ref)
        if not np.any(ok) or not np.all(np.isfinite(got[ok])):
            return None
        if np.max(np.abs(got[ok] - ref[ok]) / np.abs(ref[ok])) > _CHECK_RTOL:
            return None
        return plan

    # ---- pieces ------------------------------------------------------------------------------------
    def _form(self, theta) -> JwForm:
        """The model's :class:`JwForm` for ``theta (W, k)`` (same shapes as the probe's)."""
        form = self.model.jw_form(theta)
        if form is None or len(form.bessel) != self.n_bessel:  # pragma: no cover - fixed by the terms
            raise RuntimeError(f"model {self.model.label}: its fast form changed between calls")
        return form

    def _bessel_parts(self, form: JwForm):
        re = im = None
        for alpha, beta in form.bessel:
            br, bi = T.bessel_eddy_jw(self.omega, alpha[:, None], beta[:, None])
            re, im = (br, bi) if re is None else (re + br, im + bi)
        return re, im

    def _eval(self, coeffs):
        """``(W, 2F)``: real parts then imaginary parts of polynomials ``coeffs`` at ``jω``."""
        out = np.empty(coeffs.shape[:-1] + (2 * self.omega.size,))
        self._eval_into(coeffs, out)
        return out

    def scratch(self, shape: tuple) -> np.ndarray:
        """A reusable ``(W, F)`` array for :meth:`scaled_squared_residuals`' ``out`` (overwritten by
        the next call in this thread)."""
        return self._work.get("e", shape)

    def _folded_basis(self, Y, scale):
        """Basis rows turning ``[den coeffs, num coeffs]`` into ``c_k (D − Y_k N)`` at ``jω``."""
        key = (id(Y), id(scale))
        hit = self._folded.get(key)
        if hit is not None and hit[0] is Y and hit[1] is scale:
            return hit[2]
        even, odd = self._basis
        F = self.omega.size
        yr, yi = Y.real * scale, Y.imag * scale
        rows = []
        for k in range(self.deg_den + 1):  # D: (jω)^k times the scale
            row = np.zeros(2 * F)
            if k % 2 == 0:
                row[:F] = even[k // 2] * scale
            else:
                row[F:] = odd[k // 2] * scale
            rows.append(row)
        for k in range(self.deg_num + 1):  # −Y N: −(yr + j yi)(p_r + j p_i)
            row = np.zeros(2 * F)
            if k % 2 == 0:
                p = even[k // 2]
                row[:F], row[F:] = -yr * p, -yi * p
            else:
                p = odd[k // 2]
                row[:F], row[F:] = yi * p, -yr * p
            rows.append(row)
        M = np.array(rows)
        self._folded = {key: (Y, scale, M)}
        return M

    # ---- public --------------------------------------------------------------------------------
    def admittance(self, theta) -> np.ndarray:
        """Complex ``Y(jω)`` [S] for parameter sets ``theta (..., k)`` → ``(..., F)``."""
        theta = np.asarray(theta, float)
        lead = theta.shape[:-1]
        flat = theta.reshape(-1, theta.shape[-1])
        form = self._form(flat)
        num, den = form.num, form.den
        F = self.omega.size
        with np.errstate(all="ignore"):
            N = self._eval(num)
            D = self._eval(den)
            Zn = N[:, :F] + 1j * N[:, F:]
            Zd = D[:, :F] + 1j * D[:, F:]
            if form.bessel:
                br, bi = self._bessel_parts(form)
                Zn = Zn + (br + 1j * bi) * Zd
            Y = Zd / Zn
        return Y.reshape(lead + (F,))

    def scaled_squared_residuals(self, theta, Y, scale, out=None) -> np.ndarray:
        """``e_k = |Y_model(jω_k) − Y_k|² scale_k²`` for parameter sets ``theta (W, k)`` → ``(W, F)``
        (into ``out`` if given).

        ``Y`` (complex, ``(F,)``) and ``scale`` (real, ``(F,)``) must be the same array objects
        from call to call (the folded basis is cached on their identity). Not re-entrant within one
        thread (scratch arrays are reused); threads each get their own.
        """
        theta = np.asarray(theta, float)
        form = self._form(theta)
        num, den = form.num, form.den
        W = theta.shape[0]
        M = self._folded_basis(Y, scale)
        coeffs = np.ascontiguousarray(np.concatenate([den, num], axis=-1))
        e = np.empty((W, self.omega.size)) if out is None else out
        bessel = []
        for alpha, beta in form.bessel:  # per term: table position offset and (β/√α) D's coefficients
            with np.errstate(all="ignore"):
                half = 0.5 * np.log(alpha)
                gden = (beta * np.exp(-half))[:, None] * den
                bessel.append((T.table_position(half, 0.0), gden))
        yr, yi = Y.real * scale, Y.imag * scale
        with np.errstate(all="ignore"):
            for a in range(0, W, self.chunk):
                b = min(a + self.chunk, W)
                self._chunk(coeffs[a:b], num[a:b], M, [(p[a:b], gd[a:b]) for p, gd in bessel], yr, yi, e[a:b])
        return e

    def _chunk(self, coeffs, num, M, bessel, yr, yi, e) -> None:
        n, F, c = coeffs.shape[0], self.omega.size, self.chunk
        wk = self._work
        E = wk.get("E", (c, 2 * F))[:n]
        Tn = wk.get("T", (c, 2 * F))[:n]
        np.matmul(coeffs, M, out=E)  # c (D − Y N)
        self._eval_into(num, Tn)  # N
        if bessel:
            D = wk.get("D", (c, 2 * F))[:n]
            pos, hr, hi, frac, tmp, bdr, bdi = (wk.get(k, (c, F))[:n] for k in
                                                ("pos", "hr", "hi", "frac", "tmp", "bdr", "bdi"))
            idx = wk.get("idx", (c, F), np.intp)[:n]
            for i, (p0, gden) in enumerate(bessel):  # B D = Σ h (β/√α) D
                self._eval_into(gden, D)
                np.add(p0[:, None], self._pos_omega, out=pos)
                T.bessel_h_into(pos, hr, hi, idx, frac, tmp)
                dr, di = D[:, :F], D[:, F:]
                if i == 0:
                    np.multiply(hr, dr, out=bdr)
                    np.multiply(hr, di, out=bdi)
                else:
                    bdr += np.multiply(hr, dr, out=tmp)
                    bdi += np.multiply(hr, di, out=tmp)
                bdr -= np.multiply(hi, di, out=tmp)
                bdi += np.multiply(hi, dr, out=tmp)
            Tn[:, :F] += bdr  # T = N + B D
            Tn[:, F:] += bdi
            Er, Ei = E[:, :F], E[:, F:]  # E −= c Y (B D)
            Er -= np.multiply(bdr, yr, out=tmp)
            Er += np.multiply(bdi, yi, out=tmp)
            Ei -= np.multiply(bdi, yr, out=tmp)
            Ei -= np.multiply(bdr, yi, out=tmp)
        np.square(E, out=E)
        np.square(Tn, out=Tn)
        np.add(E[:, :F], E[:, F:], out=e)
        np.add(Tn[:, :F], Tn[:, F:], out=Tn[:, :F])
        np.divide(e, Tn[:, :F], out=e)

    def _eval_into(self, coeffs, out) -> None:
        """``out (n, 2F)`` = real parts then imaginary parts of polynomials ``coeffs`` at ``jω``."""
        even, odd = self._basis
        F = self.omega.size
        ne, no = (coeffs.shape[-1] + 1) // 2, coeffs.shape[-1] // 2
        np.matmul(np.ascontiguousarray(coeffs[:, 0::2]), even[:ne], out=out[:, :F])
        if no:
            np.matmul(np.ascontiguousarray(coeffs[:, 1::2]), odd[:no], out=out[:, F:])
        else:
            out[:, F:] = 0.0
