"""Hi-fi virtual three-point test of one case: parameters from the config, run, artefacts.

Artefacts (``outdir``): ``energies.csv`` (time, KE, every absorbed-energy family, W_ext,
balance), ``slip_out.csv`` (axial slip of every wire end relative to the covering end),
``shapes/`` (VTU per instant + PVD) and ``shapes.png``; ``out_csv``
(``deflection_mm,force_N`` at the feeder) and ``summary_json`` (the DESIGN summary
fields plus the parameters used).  Everything is written only after the run
succeeded, each file atomically.
"""
from __future__ import annotations

from pathlib import Path


from harnesspipe.config import ConfigError
from harnesspipe.input_files import read_csv
from harnesspipe.validate import (check, interface_problem, problem, stop_problem,
                                  tape_tension_problem)

#: keys of ``--set`` and their place: interface/explicit parameters, resolution, coverings
INTERFACE_KEYS = ("mu_rtb", "mu_rtp", "delta0", "delta_f", "alpha_d", "E2_over_E1", "mu_s",
                  "mu_k", "d_c", "K_nn", "K_ss", "K_tt")
EXPLICIT_KEYS = ("t_total", "rate_ramp", "f_m", "safety", "mass_damping", "penalty", "penalty_layers",
                 "search_margin", "tie_damping", "stop_deflection")
BUILD_KEYS = ("pack_angle", "wire_fill", "tube_closure", "sleeve_closure", "end_tape_layers", "end_tape_binds",
              "fabric_end_tape_layers", "fabric_end_tape_binds",
              "tape_tension")    # the specimen's build state (config hifi.build)
COVERINGS = ("closed_tube", "open_tube", "fabric_tube")
TUBES = ("closed_tube", "open_tube")             # their corrugation pitch is a --set key too


def case_definition(cfg: dict, case: str) -> dict:
    cases = dict(cfg["cases"])
    cases.update(cfg["hifi"].get("extra_cases", {}))
    if case not in cases:
        raise ConfigError(f"--case {case!r}: not a case of the config (one of {sorted(cases)})")
    return dict(cases[case])


def covering_properties(cfg: dict, table2: Path | None, values: dict | None = None) -> dict:
    """E, sigma_y, K, n per covering: ``values`` (a campaign's, read from a Table 2 before),
    the tensile stage's Table 2 CSV, else the config."""
    if values is not None:
        return {k: dict(v) for k, v in values.items()}
    if table2 is None:
        source = cfg["hifi"]["coverings"]
        if source != "paper":
            raise ConfigError(f"hifi.coverings: {source!r}: expected 'paper' or pass --coverings")
        return {k: dict(v) for k, v in cfg["paper"]["table2"].items()}
    frame = read_csv(table2, dtype=str)          # values as written, for the messages
    missing = {"component", "E", "sigma_y", "K", "n"} - set(frame.columns)
    if missing:
        raise ConfigError(f"{table2}: missing columns {sorted(missing)}")
    out = {}
    for line, row in enumerate(frame.itertuples(), start=2):
        values = {k: getattr(row, k) for k in ("E", "sigma_y", "K", "n")}
        bad = check(values, f"{table2}: line {line}: {row.component}.")
        if bad:
            raise ConfigError(bad[0])
        out[row.component] = {k: float(v) for k, v in values.items()}
    absent = [c for c in COVERINGS if c not in out]
    if absent:
        raise ConfigError(f"{table2}: no row for {', '.join(absent)}: expected a Table 2 row "
                          f"per covering ({', '.join(COVERINGS)})")
    return out


def parameters(cfg: dict, overrides: dict, table2: Path | None = None,
               interface: dict | None = None, covering_values: dict | None = None) -> dict:
    """Everything a run needs, as plain values: interface, explicit, resolution, coverings,
    build.  ``interface`` (e.g. from :func:`interface_choice`) replaces the config's start
    values (``hifi.parameters``; its build-state keys the config's ``hifi.build``); the
    ``--set`` ``overrides`` come last; ``covering_values``: see :func:`covering_properties`.
    Bad values raise ConfigError naming the key."""
    from harnesspipe.config import resolution
    p = {
        "interface": {**cfg["interfaces"], **cfg["hifi"]["parameters"]},
        "explicit": {**cfg["hifi"]["explicit"], "f_m": cfg["explicit"]["f_m"]},
        "resolution": dict(resolution(cfg)["hifi"]),
        "coverings": covering_properties(cfg, table2, covering_values),
        "build": dict(cfg["hifi"]["build"]),
        "geometry": {},             # --set <tube>.pitch: the corrugation pitch (an assumption)
    }
    for key, value in (interface or {}).items():
        p["build" if key in BUILD_KEYS else "interface"][key] = float(value)
    for key, text in overrides.items():
        try:
            value = float(text)
        except ValueError:
            raise ConfigError(f"--set {key}={text}: not a number") from None
        bad = problem(key, value)
        if bad:
            raise ConfigError(f"--set {key}={text}: {bad}")
        group, _, name = key.rpartition(".")
        if group in COVERINGS and name in ("E", "sigma_y", "K", "n"):
            p["coverings"][group][name] = value
        elif group in TUBES and name == "pitch":
            p["geometry"].setdefault(group, {})["pitch"] = value
        elif key in INTERFACE_KEYS:
            p["interface"][key] = value
        elif key in EXPLICIT_KEYS:
            p["explicit"][key] = value
        elif key in BUILD_KEYS:
            p["build"][key] = value
        elif key in p["resolution"]:
            p["resolution"][key] = int(value) if float(value).is_integer() else value
        else:
            allowed = dict.fromkeys([*INTERFACE_KEYS, *EXPLICIT_KEYS, *BUILD_KEYS,
                                     *sorted(p["resolution"]),
                                     *(f"{c}.E|sigma_y|K|n" for c in COVERINGS),
                                     *(f"{c}.pitch" for c in TUBES)])
            raise ConfigError(f"--set {key}: unknown parameter (one of {', '.join(allowed)})")
    from harnesspipe.models.hifi_bundle import KE_IE_FROM
    stop = stop_problem(p["explicit"].get("stop_deflection", 0.0),
                        cfg["three_point"]["deflection"], KE_IE_FROM)
    if stop:
        raise ConfigError(f"stop_deflection={p['explicit']['stop_deflection']:g}: {stop}")
    relation = interface_problem(p["interface"])
    if relation and (interface or overrides.keys() & {"delta0", "delta_f"}):
        source = "--set " if overrides.keys() & {"delta0", "delta_f"} else "interface: "
        raise ConfigError(source + relation)
    return p


def interface_choice(cfg: dict, choice: str | Path) -> tuple[str, dict]:
    """The interface a run starts from, and its label: ``"paper"`` (config ``paper.interface``,
    Sec. 4.2), ``"start"`` (config ``hifi.parameters``, the calibration's start values) or an
    interface.csv (``parameter,value`` as the pipeline's hifi_interface rule writes it; its
    build-state rows, e.g. ``end_tape_layers``, set the specimen's build)."""
    if str(choice) in ("paper", "start"):
        values = cfg["paper"]["interface"] if str(choice) == "paper" else cfg["hifi"]["parameters"]
        label = ("paper (Sec. 4.2, config paper.interface)" if str(choice) == "paper"
                 else "start (config hifi.parameters)")
        return label, {k: float(v) for k, v in values.items()}
    path = Path(choice)
    if not path.is_file():
        raise ConfigError(f"--interface {choice}: expected paper, start or an interface.csv file")
    frame = read_csv(path, dtype=str)
    if list(frame.columns[:2]) != ["parameter", "value"]:
        raise ConfigError(f"{path}: line 1: expected the columns parameter,value")
    values = {}
    for line, row in enumerate(frame.itertuples(), start=2):
        if row.parameter not in INTERFACE_KEYS + BUILD_KEYS:
            raise ConfigError(f"{path}: line {line}: {row.parameter!r}: not an interface or build "
                              f"parameter (one of {', '.join(INTERFACE_KEYS + BUILD_KEYS)})")
        if row.parameter in values:
            raise ConfigError(f"{path}: line {line}: {row.parameter} given twice")
        bad = problem(row.parameter, row.value)
        if bad:
            raise ConfigError(f"{path}: line {line}: {row.parameter}={row.value}: {bad}")
        values[row.parameter] = float(row.value)
    absent = [k for k in cfg["paper"]["interface"] if k not in values]
    if absent:
        raise ConfigError(f"{path}: no row for {', '.join(absent)}: an interface.csv gives every "
                          "Sec. 4.2 parameter (to change one, --set it on top of --interface paper "
                          "or start)")
    relation = interface_problem(values)
    if relation:
        raise ConfigError(f"{path}: {relation}")
    return str(path), values


def inputs(cfg: dict, case: str, overrides: dict, table2: Path | None = None,
           interface: dict | None = None, covering_values: dict | None = None):
    """The :class:`harnesspipe.models.hifi_bundle.HifiInputs` of one run from the config
    (``interface``, ``overrides``, ``covering_values``: see :func:`parameters`)."""
    from harnesspipe.models.hifi_bundle import HifiInputs
    from harnesspipe.models.hifi_mesh_parts import tape_material
    p = parameters(cfg, overrides, table2, interface, covering_values)
    res = p["resolution"]
    definition = case_definition(cfg, case)
    tension = p["build"].get("tape_tension", 0.0)
    bad = tape_tension_problem(tension, tape_material(cfg, definition))
    if bad:
        raise ConfigError(f"tape_tension={tension:g}: {bad}")
    t_total = p["explicit"].get("t_total", res["t_total"] * definition.get("t_total_scale", 1.0))
    explicit = {**p["explicit"], "t_total": float(t_total)}
    cfg = {**cfg, "hifi": {**cfg["hifi"], "build": p["build"]},      # --set build keys
           "coverings": {c: {**v, **p["geometry"].get(c, {})} for c, v in cfg["coverings"].items()}}
    return HifiInputs(definition, cfg, p["interface"], explicit,
                      {k: v for k, v in res.items() if k != "t_total"}, p["coverings"])


def run_case(cfg: dict, case: str, overrides: dict, *, coverings: Path | None, out_csv: Path,
             summary_json: Path, outdir: Path, interface: dict | None = None,
             interface_source: str = "config hifi.parameters", progress=None,
             covering_values: dict | None = None) -> dict:
    """Run one virtual test and write its artefacts; returns the summary.  ``progress``: the
    model's progress callback (:func:`harnesspipe.models.hifi.three_point`);
    ``covering_values``: see :func:`covering_properties`."""
    from harnesspipe.models.hifi import three_point
    from harnesspipe.stages.common import write_csv, write_json
    inp = inputs(cfg, case, overrides, coverings, interface, covering_values)
    run = three_point(inp, progress=progress)
    outdir = Path(outdir)
    write_csv(outdir / "energies.csv", run.history)
    write_csv(outdir / "slip_out.csv", run.slip_out)
    write_shapes(outdir, run)
    summary = {"case": case, "profile": cfg["profile"], **run.summary,
               "interface_source": interface_source,
               "parameters": {"interface": inp.interface, "explicit": inp.explicit,
                              "resolution": inp.resolution, "coverings": inp.coverings,
                              "build": inp.config["hifi"]["build"]}}
    write_csv(out_csv, run.curve)
    write_json(summary_json, summary)
    return summary


def write_shapes(outdir: Path, run) -> None:
    """Bent shapes: one VTU per instant (meshio) + a PVD series + a side-view PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from harnesspipe.models.hifi_mesh import write_vtu
    folder = Path(outdir) / "shapes"
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for k, (defl, x) in enumerate(sorted(run.shapes.items())):
        name = f"shape_{k:02d}.vtu"
        write_vtu(folder / name, run.mesh, x)
        entries.append(f'    <DataSet timestep="{defl:.6g}" file="{name}"/>')
    (folder / "shapes.pvd").write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")
    mesh = run.mesh
    fig, ax = plt.subplots(figsize=(8, 3.2))
    centre = mesh.wire_nodes[int(((mesh.wire_yz**2).sum(axis=1)).argmin())]
    for defl, x in sorted(run.shapes.items()):
        ax.plot(x[centre, 0], x[centre, 1], label=f"{defl:.1f} mm")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("centre wire at the feeder deflections")
    ax.legend(fontsize=7)
    ax.set_aspect("equal")
    fig.tight_layout()
    fig.savefig(Path(outdir) / "shapes.png", dpi=110)
    plt.close(fig)
