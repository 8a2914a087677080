"""Warnings as one short line each: code, band in Hz, a short hint; records that say the same
thing about several models (or outputs) merged. Shared by the terminal (``cli``) and the report;
the full text stays in the JSON records."""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping

__all__ = ["band_hz", "short_hint", "group_warnings"]

_WORST = re.compile(r"largest in ([0-9.e+-]+)[–-]([0-9.e+-]+) Hz")
_BAND = re.compile(r"in ([0-9.e+-]+)[–-]([0-9.e+-]+) Hz")
_MODEL_PREFIX = re.compile(r"^([A-Za-z0-9()+_]{1,40}): (.+)$", re.S)
_TERMS = ("enclosure_port", "second_resonance", "suspension_creep", "semi_inductance", "winding_capacitance",
          "lr2", "lead_impedance", "thermal_drift", "measurement_artifact", "eddy")


def band_hz(w: Mapping) -> str:
    """`` LO-HI Hz``: the record's ``band_hz`` (or ``band_rad_s``), else the band its message names
    first (for an inadequate fit, the worst band); ``""`` when none."""
    band = w.get("band_hz")
    if not band and w.get("band_rad_s"):
        band = [b / (2 * math.pi) for b in w["band_rad_s"]]
    if not band:
        text = str(w.get("message", ""))
        m = _WORST.search(text) or _BAND.search(text)
        if m:
            try:
                band = [float(m.group(1)), float(m.group(2))]
            except ValueError:
                band = None
    return "" if not band else f" {band[0]:.3g}-{band[1]:.3g} Hz"


def short_hint(code: str, message: str, width: int = 72) -> str:
    """A short hint: for an inadequate model the residual-to-noise ratio and the physics terms the
    message suggests; otherwise the message's first clause, at most ``width`` characters."""
    if code == "model_inadequate":
        m = re.search(r"up to ([0-9.e+]+) times the noise", message)
        # the terms the advice names ("try: ..."), less those the model already holds (its label
        # opens the message: "UD+enclosure_port cannot describe these data: ...")
        head, _, advice = message.partition("try:")
        label = head.split(" cannot describe", 1)[0] if " cannot describe" in head else ""
        held = set(label.split("+")[1:])
        terms = [t for t in _TERMS if t in (advice or message) and t not in held]
        hint = f"residuals up to {m.group(1)}x the noise" if m else "residuals above the noise"
        return hint + (f"; try {', '.join(terms[:3])}" if terms else "")
    first = " ".join(re.split(r"(?<=[a-z)])\. |; ", message, maxsplit=1)[0].split())
    return first if len(first) <= width else first[: width - 1].rstrip() + "…"


def group_warnings(records: Iterable, *, default_source: str | None = None) -> list[dict]:
    """``[{"code", "band", "short", "sources", "messages"}]``, one per distinct (code, band, hint),
    in first-seen order. A record is ``{"code", "message"}`` with optional ``short``, ``model``,
    ``models`` or ``source``; a plain string is a message without a code."""
    merged: dict[tuple, dict] = {}
    for w in records:
        if not isinstance(w, Mapping):
            w = {"code": "", "message": str(w)}
        code, msg = str(w.get("code") or ""), str(w.get("message", ""))
        srcs = list(w.get("models") or [])
        prefix = None
        m = _MODEL_PREFIX.match(msg)
        if m:  # "UD: ..." names the model the message is about: a source, not part of the hint
            prefix, msg = m.group(1), m.group(2)
        short = str(w.get("short") or short_hint(code, msg))
        key = (code, band_hz({**w, "message": msg}), short)
        for k in ("model", "source"):
            if w.get(k):
                srcs.append(str(w[k]))
        if not srcs and default_source:
            srcs = [default_source]
        if prefix:
            srcs = [f"{x} {prefix}" for x in srcs] or [prefix]
        g = merged.setdefault(key, {"code": code, "band": key[1], "short": short, "sources": [],
                                    "messages": []})
        g["sources"] += [s for s in srcs if s not in g["sources"]]
        if msg not in g["messages"]:
            g["messages"].append(msg)
    return list(merged.values())
