"""``bayes-emt report RUN_DIR``: rebuild the HTML report from a run folder's saved outputs.

Reads the JSON files, netCDF posterior and PNG figures the demo or the individual commands wrote
into RUN_DIR, each JSON file by the kind of result it records whatever its name (fit --json,
sample --json, ts --json, diagnose --json, compare --json, shunt --json), and renders one
self-contained HTML page (figures embedded): warnings on top, the Thiele-Small table with the fit
and its 90 % band, the data, fits with units, evidence, posterior, shunt designs (nominal and
robust) and the diagnosis. A section whose outputs are absent says that it was not run. Nothing
is recomputed, except the posterior's Bode and corner figures, redrawn from the folder's netCDF
posterior when no PNG of them exists.
"""

from __future__ import annotations

from ._common import add_output_args, add_parser

EXAMPLES = """\
bayes-emt report demo_run  (rebuild demo_run/report.html from what demo --out demo_run saved)
bayes-emt report demo_run --out /tmp/r.html  (write it elsewhere)
bayes-emt report demo_run --screenshot shot.png  (and check it renders: a headless Chromium screenshot)
bayes-emt report results/  (where fit, sample, ts, diagnose and shunt saved their --json and --plot outputs)
"""


def register(sub) -> None:
    p = add_parser(sub, "report", help="rebuild the HTML report of a run folder from its saved outputs",
                   description=__doc__, examples=EXAMPLES)
    p.add_argument("run_dir", metavar="RUN_DIR",
                   help="a folder of saved results (what demo --out writes, or the commands' outputs)")
    p.add_argument("--out", default=None, metavar="HTML", help="report file (default RUN_DIR/report.html)")
    p.add_argument("--screenshot", default=None, metavar="PNG",
                   help="also render the report in headless Chromium and save a screenshot here")
    p.add_argument("--width", type=int, default=1200, help="screenshot width [CSS px] (default 1200)")
    p.add_argument("--height", type=int, default=3000, help="screenshot height [CSS px] (default 3000)")
    add_output_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from pathlib import Path

    from ...report import build_report

    root = Path(args.run_dir)
    if not root.is_dir():
        raise FileNotFoundError(f"{args.run_dir}: no such run folder")
    if args.out is not None and Path(args.out).suffix.lower() not in (".html", ".htm"):
        raise ValueError(f"--out {args.out}: the report must be an .html file (so it never replaces a "
                         "saved output)")
    path = build_report(root, args.out)
    if args.verbose:
        from ...report.load import RunFiles
        from ...report.sections import collect_sections

        rf = RunFiles(root)
        for s in collect_sections(rf, rf.json("run.json")):
            print(f"  {s['title']}: " + ("rendered" if s["ran"] else s["absent"]))
    if not args.quiet:
        print(f"wrote {path.resolve()}")
    if args.screenshot:
        from ...report.browser import BrowserError, screenshot

        if Path(args.screenshot).suffix.lower() != ".png":
            raise ValueError(f"--screenshot {args.screenshot}: must be a .png file")
        try:
            shot = screenshot(path, args.screenshot, width=args.width, height=args.height)
        except BrowserError as exc:
            raise ValueError(f"--screenshot: {exc}") from None
        if not args.quiet:
            print(f"wrote {shot} (headless Chromium, {args.width} x {args.height} px)")
    return 0
