"""Argument helpers shared by sub-commands."""

from __future__ import annotations

import argparse

from ...models import MODEL_NAMES

__all__ = ["add_data_args", "add_model_args", "print_table"]


def add_data_args(p: argparse.ArgumentParser) -> None:
    """Options that say how to read a measurement file when its header does not."""
    p.add_argument("--freq-unit", choices=["hz", "rad/s"], default=None,
                   help="frequency column unit, when the file does not say (zma files are Hz)")
    p.add_argument("--phase-unit", choices=["deg", "rad"], default=None,
                   help="phase column unit, when the file does not say")
    p.add_argument("--quantity", choices=["Z", "Y"], default=None,
                   help="whether the file holds impedance Z or admittance Y, when it does not say")
    p.add_argument("--omega-min", type=float, default=None, help="ignore points below (rad/s)")
    p.add_argument("--omega-max", type=float, default=None, help="ignore points above (rad/s)")


def add_model_args(p: argparse.ArgumentParser, *, required: bool = True) -> None:
    p.add_argument("--model", required=required, type=str.upper, choices=list(MODEL_NAMES),
                   help="coil model (SPEC §2)")
    p.add_argument("--rings", type=int, default=None, help="rings for NL/UL (default 5)")
    p.add_argument("--n-turns", type=float, default=480.0, help="coil turns N (NL/UL; default 480)")


def print_table(rows: list[tuple], header: tuple) -> None:
    """Print an aligned text table."""
    cols = list(zip(*([header] + [tuple(str(c) for c in r) for r in rows]), strict=True))
    widths = [max(len(c) for c in col) for col in cols]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    print(fmt.format(*header))
    print("  ".join("-" * w for w in widths))
    for r in rows:
        print(fmt.format(*(str(c) for c in r)))
