"""Manufacturers' published Thiele–Small values of drivers recorded in ``../shared/realdata``, for
comparison with what :func:`~bayes_emt.thiele_small.thiele_small` measures (the benchmark page of the docs).

Each entry is SI (the units of :data:`~bayes_emt.thiele_small.relations.UNITS`) with its source.

Dayton Audio LS10-44 (10" shallow-mount subwoofer, two 4 Ω voice coils): the values of Dayton
Audio's product page https://www.daytonaudio.com/product/1257/ls10-44-10-low-profile-subwoofer-dual-4-ohm
(spec sheet https://www.daytonaudio.com/images/resources/295-251--dayton-audio-ls10-44-spec-sheet.pdf),
as scraped on 2026-06-30 into the WinISD driver file ``drivers/dayton-audio/Dayton_Audio_LS10-44.wdr``
of the public repository Johnlon/resonate (commit 2f7006ffcd3e9b7bb19ceca49f678a8f323b9f5a), whose
sidecar ``Dayton_Audio_LS10-44_meta.yml`` says "scraped, not human verified". Re = 7.4 Ω is the two
coils **in series** (in parallel about 1.85 Ω, one coil about 3.7 Ω); the recordings
``dayton_LS10-44_*_run2.txt`` have Re Z(1 Hz) = 7.40 Ω, so they were measured in series too and
Re, Bl and Qes compare directly. The set is consistent with the T/S relations to 2 % (Qes =
ωs Mms Re/Bl² = 0.473 against 0.47: both coils driven; ``tests/test_ts_published.py``). The data
sheet does not say at which frequency its Le is taken.
"""

from __future__ import annotations

__all__ = ["LS10_44", "LS10_44_SOURCE"]

LS10_44_SOURCE = ("Dayton Audio product page https://www.daytonaudio.com/product/1257/"
                  "ls10-44-10-low-profile-subwoofer-dual-4-ohm (spec sheet 295-251), as scraped into "
                  "Johnlon/resonate drivers/dayton-audio/Dayton_Audio_LS10-44.wdr "
                  "(commit 2f7006ffcd3e9b7bb19ceca49f678a8f323b9f5a; not human verified)")

#: SI values; ``Sd`` [m²], ``Xmax`` [m] and the air the file states (``rho`` [kg/m³], ``c`` [m/s])
#: beside the T/S set; coils in series
LS10_44 = {
    "fs": 34.3,
    "Re": 7.4,
    "Le": 5.25e-3,
    "Qms": 5.15,
    "Qes": 0.47,
    "Qts": 0.43,
    "Bl": 21.1,
    "Mms": 0.132,
    "Cms": 0.16e-3,
    "Vas": 0.0308,
    "Sd": 0.03664,
    "Xmax": 0.010,
    "rho": 1.20095217714682,
    "c": 343.684120962152,
}
