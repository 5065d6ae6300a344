"""``harnesspipe hifi three-point`` and ``hifi branch``: the high-fidelity virtual bending test
(Sec. 4.1) and the pull test of the Y-shaped branching harness (Sec. 5, Fig. 18a)."""
from __future__ import annotations

from pathlib import Path

from harnesspipe.commands.paths import input_file, output_dir, output_file

#: the calibrated interface the pipeline writes (hifi_interface rule), relative to the cwd
CALIBRATED = Path("results/hifi/interface.csv")


def _assignment(text: str) -> tuple[str, str]:
    import argparse
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"--set {text!r}: expected key=value, e.g. mu_rtb=0.25")
    return key.strip(), value.strip()


def register(sub) -> None:
    hifi = sub.add_parser("hifi", help="high-fidelity (mesoscale) bundle models")
    hsub = hifi.add_subparsers(dest="hifi_command", required=True, metavar="MODEL")
    p = hsub.add_parser("three-point", help="explicit three-point bending of a wire bundle")
    p.add_argument("--case", required=True, help="case name (config `cases` / `hifi.extra_cases`)")
    p.add_argument("--profile", default=None, help="resolution profile (config `profiles`)")
    p.add_argument("--config", type=input_file, default=None, help="config file (default: the package's)")
    p.add_argument("--coverings", type=input_file, default=None,
                   help="table2.csv of the tensile stage (default: config hifi.coverings)")
    p.add_argument("--interface", default=None, metavar="paper|start|FILE",
                   help="interface values of the run: paper (Sec. 4.2: mu_rtb 0.3, mu_rtp 0.1, "
                        "delta0 0.03, delta_f 0.08, alpha_d 2, E2/E1 0.6), start (config "
                        "hifi.parameters, the calibration's start values) or an interface.csv "
                        f"(parameter,value); default: {CALIBRATED} when it exists, else paper")
    p.add_argument("--set", dest="overrides", type=_assignment, action="append", default=[],
                   metavar="KEY=VALUE",
                   help="override one value on top of --interface, e.g. mu_rtb=0.25 (repeatable)")
    p.add_argument("--out", type=output_file, required=True, help="CSV: deflection_mm,force_N")
    p.add_argument("--summary", type=output_file, default=None,
                   help="summary JSON (default: summary.json in the --outdir folder)")
    p.add_argument("--threads", type=int, default=None,
                   help="Numba threads (default: all cores, which sleep when idle, so another "
                        "job on the machine does not stall them: OMP_WAIT_POLICY=passive unless "
                        "set; Snakemake passes its `threads`)")
    p.add_argument("--outdir", type=output_dir, default=None,
                   help="folder for energies, slip-out, shapes (default: OUT_files beside --out)")
    p.set_defaults(func=_three_point)

    p = hsub.add_parser("branch", help="explicit pull test of the Y-shaped branching harness (Fig. 18a)")
    p.add_argument("--load-case", choices=("inplane", "outofplane"), default=None,
                   help="default: config branch.hifi.load_case")
    p.add_argument("--t-total", type=float, default=None,
                   help="simulated seconds of the 50 mm pull (default: config branch.hifi.t_total)")
    p.add_argument("--profile", default=None, help="resolution profile (config `profiles`)")
    p.add_argument("--config", type=input_file, default=None, help="config file (default: the package's)")
    p.add_argument("--coverings", type=input_file, default=None,
                   help="table2.csv of the tensile stage (default: config hifi.coverings)")
    p.add_argument("--threads", type=int, default=None,
                   help="Numba threads (default: all cores, sleeping when idle: see three-point)")
    p.add_argument("--out", type=output_file, required=True, help="CSV: displacement_mm,force_N")
    p.add_argument("--summary", type=output_file, default=None,
                   help="summary JSON (default: summary.json in the --outdir folder)")
    p.add_argument("--outdir", type=output_dir, default=None,
                   help="folder for energies and S2's bent shapes (default: OUT_files beside --out)")
    p.set_defaults(func=_branch)


def _config(args) -> dict:
    """The config of a run with --threads and --profile applied (bad values: InputError)."""
    from harnesspipe.cli import InputError
    from harnesspipe.config import load
    if args.threads is not None:
        import numba
        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            raise InputError(f"--threads {args.threads}: expected 1..{numba.config.NUMBA_NUM_THREADS}")
        numba.set_num_threads(args.threads)
    cfg = load(args.config) if args.config else load()
    if args.profile is not None:
        if args.profile not in cfg["profiles"]:
            raise InputError(f"--profile {args.profile!r}: not one of {sorted(cfg['profiles'])}")
        cfg["profile"] = args.profile
    return cfg


def _interface(cfg: dict, choice: str | None) -> tuple[str, dict]:
    """The run's interface (``--interface``, default: the calibrated one, else the paper's)."""
    from harnesspipe.stages.hifi import interface_choice
    if choice is None:
        choice = str(CALIBRATED) if CALIBRATED.is_file() else "paper"
    return interface_choice(cfg, choice)


def _outdir(args) -> Path:
    """--outdir, by default OUT_files beside --out (checked here: argparse checks a given one)."""
    from harnesspipe.cli import InputError
    outdir = args.outdir or args.out.parent / f"{args.out.stem}_files"
    if outdir.exists() and not outdir.is_dir():
        raise InputError(f"--out {args.out}: {outdir} (the default --outdir) is a file, expected a folder")
    return outdir


def _wrote(*paths) -> None:
    print("wrote " + ", ".join(str(p) for p in paths))


def _three_point(args) -> int:
    from harnesspipe.progress import Progress
    from harnesspipe.stages.hifi import parameters, run_case

    cfg = _config(args)
    label, interface = _interface(cfg, args.interface)
    overrides = dict(args.overrides)
    used = parameters(cfg, overrides, args.coverings, interface)      # every input checked here
    shown = {k: used["interface"][k] for k in cfg["paper"]["interface"]}
    shown.update((k, used["build"][k]) for k in interface if k in used["build"])
    print(f"interface: {label}: " + ", ".join(
        f"{k} {v:g}" + (" (--set)" if k in overrides else "") for k, v in shown.items()), flush=True)
    outdir = _outdir(args)
    summary_json = args.summary or outdir / "summary.json"
    progress = Progress(args.case)
    try:
        summary = run_case(cfg, args.case, overrides, coverings=args.coverings, out_csv=args.out,
                           summary_json=summary_json, outdir=outdir, interface=interface,
                           interface_source=label, progress=progress)
    finally:
        progress.close()
    print(f"{args.case}: {summary['steps']} steps, dt {summary['dt']:.3g} s, "
          f"wall {summary['wall_s']:.1f} s, KE/IE max {summary['ke_ie_max']:.3g}, "
          f"energy error {summary['energy_error']:.3g}")
    _wrote(args.out, summary_json, f"{outdir}/")
    return 0


def _branch(args) -> int:
    from harnesspipe.progress import Progress
    from harnesspipe.stages.branch_hifi import run, settings_from_config

    cfg = _config(args)
    if args.t_total is not None and not args.t_total > 0:
        from harnesspipe.cli import InputError
        raise InputError(f"--t-total {args.t_total}: expected a positive time")
    outdir = _outdir(args)
    summary_json = args.summary or outdir / "summary.json"
    settings = settings_from_config(cfg, args.load_case, args.t_total)
    progress = Progress(f"branch {settings['load_case']}", travel="displacement")
    try:
        summary = run(settings, outdir, table2=args.coverings, curve_csv=args.out,
                      summary_json=summary_json, progress=progress)
    finally:
        progress.close()
    print(f"branch {summary['load_case']}: {summary['steps']} steps, dt {summary['dt']:.3g} s, "
          f"wall {summary['wall_s']:.1f} s, KE/IE max {summary['ke_ie_max']:.3g}, "
          f"energy error {summary['energy_error']:.3g}")
    _wrote(args.out, summary_json, f"{outdir}/")
    return 0
