"""Argument helpers shared by sub-commands: option groups, checked number types, tables.

The number types reject a bad value while the options are parsed, so the message names the
option (``argument --seed: must be a non-negative integer, got '-1'``) instead of surfacing
later from deep inside a library.
"""

from __future__ import annotations

import argparse
import math

from ...models import AUGMENTATIONS, MODEL_NAMES

__all__ = ["add_data_args", "add_model_args", "print_table", "print_warnings", "seed", "int_at_least",
           "positive_float", "finite_float", "quantity", "nonnegative_float", "model_from_args",
           "check_model_matches",
           "add_parser", "add_output_args", "note", "detail", "progress_of"]


def seed(text: str) -> int:
    """A random seed: a non-negative integer (numpy's ``SeedSequence`` and emcee refuse others)."""
    try:
        val = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}") from None
    if val < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text!r}")
    return val


def int_at_least(low: int, why: str = ""):
    """An integer type for argparse that refuses values below ``low`` (``why`` explains the bound)."""

    def parse(text: str) -> int:
        try:
            val = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}, got {text!r}") from None
        if val < low:
            raise argparse.ArgumentTypeError(f"must be an integer >= {low}{why}, got {text!r}")
        return val

    parse.__name__ = f"integer >= {low}"
    return parse


def _float(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, got {text!r}") from None


def finite_float(text: str) -> float:
    val = _float(text)
    if not math.isfinite(val):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return val


def positive_float(text: str) -> float:
    val = _float(text)
    if not (math.isfinite(val) and val > 0):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text!r}")
    return val


def nonnegative_float(text: str) -> float:
    val = _float(text)
    if not (math.isfinite(val) and val >= 0):
        raise argparse.ArgumentTypeError(f"must be a non-negative finite number, got {text!r}")
    return val


def quantity(dimension: str, *, bare: str | None = None, sign: str = "positive"):
    """An argparse type for a quantity with an optional unit (:mod:`bayes_emt.units`): ``8.017g``,
    ``85cm2``, ``20L``, ``10Hz``; a bare number keeps its SI meaning (frequencies: ``bare``, Hz or
    rad/s). ``sign``: ``"positive"`` (default), ``"nonzero"`` or ``"any"``. The value is returned in
    SI (frequencies in ``bare``)."""
    from ...units import UnitError, parse_quantity

    def parse(text: str) -> float:
        try:
            val = parse_quantity(text, dimension, bare=bare)
        except UnitError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        if sign == "positive" and not val > 0:
            raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
        if sign == "nonzero" and val == 0:
            raise argparse.ArgumentTypeError(f"must not be zero, got {text!r}")
        return val

    parse.__name__ = dimension
    return parse


def add_parser(sub, name: str, *, help: str, description: str | None, examples: str):
    """A sub-command parser whose ``--help`` ends with worked examples (``examples`` lines, each a
    full command line) and the exit-status table (:mod:`bayes_emt.cli.exitcodes`), and keeps the
    description's own line breaks."""
    from ..exitcodes import EPILOG

    lines = "\n".join(f"  {ln.strip()}" for ln in examples.strip().splitlines())
    return sub.add_parser(name, help=help, description=description,
                          epilog=f"examples:\n{lines}\n\n{EPILOG}",
                          formatter_class=argparse.RawDescriptionHelpFormatter)


def add_output_args(p: argparse.ArgumentParser, *, progress: bool = False) -> None:
    """``--quiet`` / ``--verbose`` (mutually exclusive). ``progress``: the command has progress bars
    (shown on a terminal unless ``--quiet``)."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--quiet", action="store_true",
                   help=("no progress bars; " if progress else "")
                   + "print the results only (no notes, no 'wrote' lines); errors and warnings still show")
    g.add_argument("--verbose", action="store_true",
                   help="also print the details: settings, intermediate values and the time taken")


def note(args, *text) -> None:
    """Print unless ``--quiet``: context around the results (headers, notes, files written)."""
    if not getattr(args, "quiet", False):
        print(*text)


def detail(args, *text) -> None:
    """Print only with ``--verbose``."""
    if getattr(args, "verbose", False):
        print(*text)


def progress_of(args) -> bool | None:
    """The ``progress`` argument of the library calls: off with ``--quiet``, else on a terminal."""
    return False if getattr(args, "quiet", False) else None


def add_data_args(p: argparse.ArgumentParser) -> None:
    """Options that say how to read a measurement file when its header does not."""
    p.add_argument("--freq-unit", choices=["hz", "rad/s"], default=None,
                   help="frequency column unit, when the file does not say (zma files are Hz)")
    p.add_argument("--phase-unit", choices=["deg", "rad"], default=None,
                   help="phase column unit, when the file does not say")
    p.add_argument("--quantity", choices=["Z", "Y"], default=None,
                   help="whether the file holds impedance Z or admittance Y, when it does not say")
    p.add_argument("--magnitude-only", action="store_true",
                   help="drop the recording's phase and fit |Z| alone (a likelihood on log|Z|); "
                        "magnitude-only exports such as Klippel's are read so without it")
    p.add_argument("--omega-min", type=quantity("frequency", bare="rad/s"), default=None, metavar="W",
                   help="ignore points below W (a bare number is rad/s; or give a unit: 10Hz, 62.8rad/s)")
    p.add_argument("--omega-max", type=quantity("frequency", bare="rad/s"), default=None, metavar="W",
                   help="ignore points above W (a bare number is rad/s; or give a unit: 2kHz)")


def band_hz(text: str) -> tuple[float, float]:
    """``F1:F2`` (F1 < F2, both positive) of ``--exclude-band``, in Hz: bare numbers are Hz, or each
    bound carries a unit (``20Hz:1kHz``, ``125rad/s:6.3krad/s``)."""
    from ...units import UnitError, parse_quantity

    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        f1, f2 = (parse_quantity(x, "frequency", bare="Hz") for x in parts)
    except UnitError as exc:
        raise argparse.ArgumentTypeError(f"--exclude-band {text!r}: {exc}") from None
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--exclude-band {text!r}: expected F1:F2 in Hz (or with units), e.g. 5200:5600 or "
            "20Hz:1kHz") from None
    if not (math.isfinite(f1) and math.isfinite(f2) and 0 < f1 < f2):
        raise argparse.ArgumentTypeError(f"--exclude-band {text!r}: need 0 < F1 < F2 (Hz)")
    return f1, f2


def add_exclude_band_arg(p: argparse.ArgumentParser) -> None:
    """``--exclude-band F1:F2`` (Hz, repeatable): points left out of the fit (a narrow feature no
    lumped model explains: cone break-up, a surround dip)."""
    p.add_argument("--exclude-band", type=band_hz, action="append", default=None, metavar="F1:F2",
                   help="leave out the points between F1 and F2 (Hz, or with units: 5.2kHz:5.6kHz; "
                        "repeatable), e.g. a cone break-up "
                        "diagnose reported as an unmodelled narrow resonance")


def add_model_args(p: argparse.ArgumentParser, *, required: bool = True) -> None:
    p.add_argument("--model", required=required, metavar="MODEL",
                   help=f"model spec: a coil model ({', '.join(MODEL_NAMES)}) optionally + physics "
                        f"terms ({', '.join(AUGMENTATIONS)}), e.g. NL+winding_capacitance")
    p.add_argument("--rings", type=int_at_least(1), default=None, help="rings for NL/UL (default 5)")
    p.add_argument("--n-turns", type=positive_float, default=480.0, help="coil turns N (NL/UL; default 480)")


def model_from_args(args):
    """The model named by ``--model``, ``--rings`` and ``--n-turns`` (errors name the option)."""
    from ...models import parse_model_spec

    try:
        return parse_model_spec(args.model, rings=args.rings, n_turns=args.n_turns)
    except ValueError as exc:
        raise ValueError(f"--model {args.model}: {exc}") from None


def check_model_matches(model, spec: str | None, where: str) -> None:
    """``--model`` given as a check: it must name the model ``where`` holds."""
    from ...errors import DataFormatError
    from ...models import parse_model_spec

    if spec is None:
        return
    try:
        wanted = parse_model_spec(spec)
    except ValueError as exc:
        raise ValueError(f"--model {spec}: {exc}") from None
    if wanted.spec != model.spec:
        raise DataFormatError(f"{where}: holds model {model.spec}, but --model {spec} was given")


def print_table(rows: list[tuple], header: tuple) -> None:
    """Print an aligned text table."""
    cols = list(zip(*([header] + [tuple(str(c) for c in r) for r in rows]), strict=True))
    widths = [max(len(c) for c in col) for col in cols]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    print(fmt.format(*header))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print(fmt.format(*(str(c) for c in r)))


def print_warnings(warnings_list, *, indent: str = "") -> None:
    """Print a result's ``warnings`` (``{"code", "message"}`` records), one per line."""
    for w in warnings_list:
        print(f"{indent}WARNING [{w['code']}]: {w['message']}")


def re_reading(text: str) -> tuple[float, float]:
    """``OHM[:SD]`` of ``--re``: an ohmmeter reading [Ω] and its standard deviation (default 1 %);
    each may carry a unit (``6.1ohm``, ``5.72:20mohm``)."""
    from ...units import UnitError, parse_quantity

    value, _, sd = text.partition(":")
    try:
        v = parse_quantity(value, "resistance")
        s = parse_quantity(sd, "resistance") if sd else 0.01 * v
    except UnitError as exc:
        raise argparse.ArgumentTypeError(f"{exc}") from None
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected OHM or OHM:SD (e.g. 5.72 or 5.72:0.02), "
                                         f"got {text!r}") from None
    if not (math.isfinite(v) and v > 0 and math.isfinite(s) and s > 0):
        raise argparse.ArgumentTypeError(f"OHM and SD must be positive numbers, got {text!r}")
    return v, s


def add_re_option(p: argparse.ArgumentParser) -> None:
    """``--re OHM[:SD]`` (an ohmmeter reading of the DC resistance) and ``--re-mode cut|prior``."""
    p.add_argument("--re", type=re_reading, default=None, metavar="OHM[:SD]",
                   help="ohmmeter reading of the coil's DC resistance [ohm], optional standard deviation "
                        "(default 1 %%); see --re-mode")
    p.add_argument("--re-mode", choices=("cut", "prior"), default="cut",
                   help="how --re counts: cut (default) R0 follows the reading alone and the other "
                        "parameters are estimated at it; prior: a Normal prior on R0 combined with the data "
                        "(diagnose always uses the reading as a prior for its candidates' evidences)")


def meter_of(args):
    """The :class:`~bayes_emt.estimation.meter.Meter` of ``--re`` / ``--re-mode``, or ``None``."""
    if getattr(args, "re", None) is None:
        return None
    from ...estimation.meter import Meter

    return Meter(args.re[0], args.re[1], getattr(args, "re_mode", "cut"))


def warning_lines(records, *, model: str | None = None) -> list[str]:
    """One terminal line per distinct warning: ``warning [code] band: short hint (models)``; records
    with the same code and band are merged (:func:`bayes_emt._warnlines.group_warnings`). The full
    text stays in the JSON and the report."""
    from ..._warnlines import group_warnings

    out = []
    for g in group_warnings(records, default_source=model):
        who = f" ({', '.join(g['sources'])})" if g["sources"] else ""
        out.append(f"warning [{g['code']}]{g['band']}: {g['short']}{who}")
    return out


def print_warning_lines(records, *, model: str | None = None) -> None:
    """Print :func:`warning_lines`."""
    for line in warning_lines(records, model=model):
        print(line)
