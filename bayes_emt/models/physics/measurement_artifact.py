"""An instrument artefact: a range switch or calibration boundary of the analyser, not
the device."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import LogUniform, ParamSpec, Uniform
from ..term import Term, col

__all__ = ["MeasurementArtifact"]


@dataclass(frozen=True)
class MeasurementArtifact(Term):
    """Above ``ωs`` the measured ``Y`` is multiplied by ``(1 + δ) e^{jψ}``: an instrument range switch
    or calibration boundary (not device physics)."""

    id = "measurement_artifact"
    stage = "measurement"
    augmentation = True
    band = "anywhere"
    device = False
    generic = True
    step_at = "omegas"
    physics = "measurement_artifact"
    description = "the instrument, not the device: a range switch or calibration boundary"
    signature = "a step in magnitude and phase at one frequency"
    parameters = (
        ParamSpec("omegas", "rad/s", r"$\omega_s$", LogUniform(1e-1, 1e7),
                  "angular frequency of an instrument range switch or calibration boundary"),
        ParamSpec("delta_s", "1", r"$\delta_s$", Uniform(-0.5, 0.5),
                  "relative magnitude step of the instrument above omegas"),
        ParamSpec("psi_s", "rad", r"$\psi_s$", Uniform(-0.5, 0.5),
                  "phase step of the instrument above omegas"),
    )

    def evaluate(self, s, v, other):
        step = np.abs(s) > col(v, 0)
        return np.where(step, (1.0 + col(v, 1)) * np.exp(1j * col(v, 2)), 1.0 + 0j)

    def start(self, ctx):
        sw, sd, sp = (self.params[n] for n in ("omegas", "delta_s", "psi_s"))
        m = np.flatnonzero(ctx.in_band())
        lr = np.log(ctx.Y / ctx.Y_base)[m]
        # a step between points k-1 and k: the median after minus the median before, over windows of
        # a few percent of the band (a smooth misfit of the base fit hardly moves in that span)
        h = max(3, lr.size // 40)
        steps = []
        for k in range(h, lr.size - h + 1):
            jump = (np.median(lr[k : k + h].real) - np.median(lr[k - h : k].real)
                    + 1j * (np.median(lr[k : k + h].imag) - np.median(lr[k - h : k].imag)))
            steps.append((abs(jump), k, jump))
        steps.sort(key=lambda c: -c[0])
        cands = []
        for st in steps:  # distinct places only
            if all(abs(st[1] - c[1]) > h for c in cands):
                cands.append(st)
            if len(cands) == 3:
                break
        out = []
        for _, k, jump in cands:
            i = m[k]
            ws = float(np.sqrt(ctx.omega[i - 1] * ctx.omega[i]))
            out.append({"omegas": sw.clip_inside(ws),
                        "delta_s": sd.clip_inside(float(np.exp(jump.real) - 1.0)),
                        "psi_s": sp.clip_inside(float(jump.imag))})
        return out
