"""Figures the report can redraw from saved outputs when their PNGs are missing.

Only the posterior's figures are redrawn (from ``posterior.nc``, the ArviZ DataTree): every other
figure needs the command that computed it. Drawing goes through :mod:`bayes_emt.plotting`.
"""

from __future__ import annotations

from pathlib import Path

from . import layout as L

__all__ = ["redraw_posterior_figures", "posterior_nc"]


def posterior_nc(root: Path) -> Path | None:
    """The folder's posterior netCDF file: ``posterior.nc``, else its one ``*.nc`` file (``sample
    --out`` under another name), else ``None``."""
    nc = root / L.POSTERIOR_NC
    if nc.is_file():
        return nc
    found = sorted(root.glob("*.nc"))
    return found[0] if len(found) == 1 else None


def redraw_posterior_figures(run_dir: str | Path) -> list[str]:
    """Draw ``posterior_bode.png`` / ``posterior_corner.png`` from ``posterior.nc`` where absent.

    Returns one line per problem (an unreadable netCDF file), never raises for one.
    """
    root = Path(run_dir)
    nc = posterior_nc(root) or root / L.POSTERIOR_NC
    # a figure sample --plot already drew (posterior_<model>_bode.png) is used as it is
    drawn = {L.POSTERIOR_BODE: "posterior_*_bode.png", L.POSTERIOR_CORNER: "posterior_*_corner.png"}
    want = [n for n, pat in drawn.items() if not (root / n).is_file() and not any(root.glob(pat))
            and not any(root.glob(f"*/{pat}"))]
    if not nc.is_file() or not want:
        return []
    from ..api import read_posterior
    from ..plotting import save_figure
    from ..plotting.posterior import plot_bode_bands, plot_corner

    try:
        post = read_posterior(nc)
    except (OSError, KeyError, TypeError, ValueError) as exc:
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return [f"{nc}: could not be read as a posterior ({first}); its figures are left out"]
    problems = []
    for name in want:
        if name == L.POSTERIOR_BODE and not hasattr(post, "predictive"):
            problems.append(f"{nc}: this kind of posterior has no Bode bands")
            continue
        fig = (plot_bode_bands(post) if name == L.POSTERIOR_BODE
               else plot_corner(post, names=corner_names(post)))
        save_figure(fig, root / name, dpi=100)
    return problems


def corner_names(post) -> list[str]:
    """The parameters a corner plot shows: the four mechanical/electrical ones, the last coil
    parameter and the relative noise scale (a 20-D corner plot is unreadable)."""
    names = list(post.names)
    core = [n for n in ("zeta", "omega0", "phi", "R0") if n in names]
    coil = [n for n in names if n not in core and not n.startswith("sigma") and n != "nu"]
    noise = [n for n in names if n == "sigma_rel"]
    return core + coil[-1:] + noise
