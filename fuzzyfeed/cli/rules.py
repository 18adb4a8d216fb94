"""``fuzzyfeed rules show|check|set|surface``: look at, validate, edit and draw rule tables."""

from __future__ import annotations

import argparse
from pathlib import Path

from fuzzyfeed.cli import COMMANDS
from fuzzyfeed.cli._common import point_count
from fuzzyfeed.errors import RuleTableError


def register(sub) -> None:
    p = sub.add_parser(
        "rules", help=COMMANDS["rules"],
        description="Rule tables of the fuzzy advisor (seed 002): TOML files with the universes, "
                    "the term breakpoints, WS, the Dk clip, the filter size, a feed floor and the "
                    "rule grid. TABLE is a shipped name (default: paper) or a .toml file.")
    rs = p.add_subparsers(dest="rules_command", metavar="ACTION", required=True)

    show = rs.add_parser("show", help="print the grid, the terms and the settings, or export",
                         description="Print a rule table. --format csv/tsv prints only the grid for "
                                     "a spreadsheet; --format toml prints the file itself (with its "
                                     "comments), e.g. to start your own table: "
                                     "`fuzzyfeed rules show --format toml > mine.toml` (its name is "
                                     "then 'mine'). Exports for other fuzzy tools (AND min, "
                                     "implication min, aggregation max, centroid; rules numbered as "
                                     "the paper's R1-R30): fcl = IEC 61131-7 FCL; fcl-fuzzylite = "
                                     "FCL as fuzzylite/QtFuzzyLite reads it; fll = fuzzylite's FLL "
                                     "(centroid resolution 100000); fis = MATLAB .fis (Mamdani).")
    show.add_argument("table", nargs="?", default=None, metavar="TABLE")
    show.add_argument("--format", choices=("text", "csv", "tsv", "toml", "fcl", "fcl-fuzzylite", "fll",
                                           "fis"), default="text",
                      help="output format (default: %(default)s)")
    show.set_defaults(run=run_show)

    imp = rs.add_parser("import", help="read an FCL, FLL or MATLAB .fis file into a rule-table .toml",
                        description="Convert FILE (.fcl in IEC or fuzzylite form, .fll, .fis) into a "
                                    "fuzzyfeed rule table. The controller must be fuzzyfeed's: inputs "
                                    "curvature and curvature_variation, output feed, AND min, "
                                    "implication min, aggregation max, centroid, one rule per pair of "
                                    "input terms. fuzzyfeed's own settings (WS, clip, filter, floor) "
                                    "come from the file's fuzzyfeed-settings comment (written by "
                                    "`rules show --format fcl/fll`), else from --settings-from. The "
                                    "table's name is the output file's name unless --name is given.")
    imp.add_argument("file", metavar="FILE", help=".fcl, .fll or .fis file")
    imp.add_argument("-o", "--output", required=True, metavar="TABLE.toml", help="rule table to write")
    imp.add_argument("--format", choices=("fcl", "fll", "fis"), default=None,
                     help="file format (default: from the suffix)")
    imp.add_argument("--settings-from", default=None, metavar="TABLE",
                     help="table whose settings a file without them takes (default: paper)")
    imp.add_argument("--name", default=None, help="name to write into the table (default: none, "
                                                  "so the file's name is the table's name)")
    imp.set_defaults(run=run_import)

    diff = rs.add_parser("diff", help="what differs between two rule tables, and where the feed changes",
                         description="List the settings, terms and grid cells that differ between "
                                     "tables A and B (files of any format rules import reads, or "
                                     "shipped names). With --shape, run both on the shape and list "
                                     "the stretches of path where the advised feed differs.")
    diff.add_argument("a", metavar="A")
    diff.add_argument("b", metavar="B")
    diff.add_argument("--shape", default=None, metavar="SHAPE", help="shape to advise with both tables")
    diff.add_argument("--points", type=point_count, default=2000, metavar="N", help="sample points (default: %(default)s)")
    diff.add_argument("--threshold-pct", type=float, default=0.01, metavar="P",
                      help="smallest feed difference reported, %% of F (default: %(default)g)")
    diff.set_defaults(run=run_diff)

    check = rs.add_parser("check", help="validate rule-table files",
                          description="Validate each file; prints one line per file. Exit code 2 and "
                                      "a one-line message (file:line, value, rule) on the first error.")
    check.add_argument("tables", nargs="*", metavar="TABLE", help="files or shipped names (default: paper)")
    check.set_defaults(run=run_check)

    set_ = rs.add_parser("set", help="change one rule of a file (comments kept)",
                         description="Set the feed label of rule (ROW, COLUMN) in FILE: ROW is a "
                                     "curvature term, COLUMN a curvature_variation term, LABEL a feed "
                                     "term. The file is validated and rewritten atomically, keeping "
                                     "its comments and layout.")
    set_.add_argument("file", metavar="FILE", help="rule-table .toml file to edit")
    set_.add_argument("row", metavar="ROW", help="curvature term, e.g. VS")
    set_.add_argument("column", metavar="COLUMN", help="curvature_variation term, e.g. M")
    set_.add_argument("label", metavar="LABEL", help="feed term, e.g. HF")
    set_.set_defaults(run=run_set)

    surf = rs.add_parser("surface", help="draw the control surface and the membership functions",
                         description="Draw feed %(k, Dk) (exact centroid) and the membership "
                                     "functions of the three variables to PNG.")
    surf.add_argument("table", nargs="?", default=None, metavar="TABLE")
    surf.add_argument("-o", "--output", required=True, metavar="FILE.png", help="PNG file to write")
    surf.set_defaults(run=run_surface)


def _describe(table) -> str:
    from fuzzyfeed.fuzzy.rule_writer import grid_text

    lines = [f"rule table {table.name!r}" + (f"  ({table.path})" if table.path else "")]
    if table.source:
        lines.append(f"source: {table.source}")
    ws = f"{table.window_mm:g} mm" if table.window_mm else f"{table.window_points} points"
    m = f"{table.filter_mm:g} mm" if table.filter_mm else f"{table.filter_points} points"
    if table.inputs == "machine":
        lines.append(f"inputs: machine (the feed that holds the contour tolerance over the programmed "
                     f"feed, here and within the settling distance); {table.filter} filter, feed floor = "
                     f"{table.feed_floor_pct:g} %")
        units = ("ratio of F", "ratio of F", "% of the programmed F, capped at 100")
    else:
        lines.append(f"features: WS = {ws}, Dk clip = {table.dk_clip_1_mm:g} 1/mm, "
                     f"{table.filter} filter M = {m}, feed floor = {table.feed_floor_pct:g} %")
        units = ("1/mm", "normalised", "% of max feed")
    for var, unit in zip(table.variables, units):
        lo, hi = var.universe
        terms = "  ".join(f"{t.label}=[{', '.join(f'{x:g}' for x in t.points)}]" for t in var.terms)
        lines.append(f"{var.name} [{lo:g}, {hi:g}] ({unit}): {terms}")
    lines.append("")
    lines.append(f"rules: IF {table.curvature.name} is ROW AND {table.curvature_variation.name} is COLUMN "
                 "THEN feed is CELL")
    lines.append(grid_text(table).rstrip("\n"))
    return "\n".join(lines)


def run_show(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table, resolve_rules_path
    from fuzzyfeed.fuzzy.rule_writer import grid_text

    if args.format == "toml":
        path = resolve_rules_path(args.table)
        load_rule_table(path)   # only print valid tables
        print(path.read_text(encoding="utf-8"), end="")
        return 0
    table = load_rule_table(args.table)
    if args.format in ("fcl", "fcl-fuzzylite", "fll", "fis"):
        from fuzzyfeed.fuzzy.formats import export_table

        print(export_table(table, args.format), end="")
    elif args.format in ("csv", "tsv"):
        print(grid_text(table, sep="," if args.format == "csv" else "\t"), end="")
    else:
        print(_describe(table))
    return 0


def run_check(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table

    for spec in args.tables or [None]:
        table = load_rule_table(spec)
        nk, nd = len(table.curvature.terms), len(table.curvature_variation.terms)
        print(f"ok: {table.path}: table {table.name!r}, {nk * nd} rules ({nk} x {nd}), "
              f"{len(table.feed.terms)} feed terms")
    return 0


def run_set(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rule_writer import set_cell

    path = Path(args.file)
    if not path.is_file():
        raise RuleTableError(f"{path}: no such file; `rules set` edits a file (copy a shipped table "
                             "first: fuzzyfeed rules show paper --format toml > mine.toml)")
    table = set_cell(path, args.row, args.column, args.label)
    print(f"{path}: rule (curvature {args.row}, curvature_variation {args.column}) -> {args.label}; "
          f"table {table.name!r} is valid")
    return 0


def run_surface(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.report.plot import plot_rule_surface

    table = load_rule_table(args.table)
    plot_rule_surface(table, args.output)
    print(f"wrote {args.output}")
    return 0


def _load_any(spec: str):
    """A table from a shipped name, a .toml, or any file ``rules import`` reads."""
    from fuzzyfeed.fuzzy.exchange import IMPORT_SUFFIXES
    from fuzzyfeed.fuzzy.formats import import_table
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table

    if Path(spec).suffix.lower() in IMPORT_SUFFIXES and Path(spec).suffix.lower() != ".toml":
        if not Path(spec).is_file():
            raise RuleTableError(f"{spec}: no such file")
        return import_table(spec)
    return load_rule_table(spec)


def run_import(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from fuzzyfeed.fuzzy.formats import import_table
    from fuzzyfeed.fuzzy.rule_reader import load_rule_table
    from fuzzyfeed.fuzzy.rule_writer import table_to_toml
    from fuzzyfeed.base.atomic import atomic_write

    src = Path(args.file)
    if not src.is_file():
        raise RuleTableError(f"{src}: no such file")
    out = Path(args.output)
    if out.suffix.lower() != ".toml":
        raise RuleTableError(f"-o {out}: must be a .toml file (a fuzzyfeed rule table)")
    base = load_rule_table(args.settings_from) if args.settings_from else None
    table = import_table(src, args.format, settings_from=base)
    name = args.name
    table = replace(table, name=name if name else out.stem)
    text = (f"# imported by `fuzzyfeed rules import` from {src.name}\n"
            + table_to_toml(table, with_name=bool(name)))
    with atomic_write(out, "w") as handle:
        handle.write(text)
    nk, nd = len(table.curvature.terms), len(table.curvature_variation.terms)
    print(f"wrote {out}: table {table.name!r}, {nk * nd} rules ({nk} x {nd}), "
          f"{len(table.feed.terms)} feed terms, from {src}")
    return 0


def run_diff(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.diff import feed_changes, table_differences

    a, b = _load_any(args.a), _load_any(args.b)
    lines = table_differences(a, b)
    print(f"rule tables {a.name!r} ({a.path}) and {b.name!r} ({b.path}): "
          + (f"{len(lines)} difference(s)" if lines else "the same controller and settings"))
    for line in lines:
        print(f"  {line}")
    if args.shape:
        from fuzzyfeed.fuzzy.advisor import advise_details
        from fuzzyfeed.io.shapes import load_shape, sample_shape

        shape = load_shape(args.shape)
        samples = sample_shape(shape, args.points)
        fa, fb = advise_details(samples, a).feed_pct, advise_details(samples, b).feed_pct
        changes = feed_changes(samples.s, fa, fb, args.threshold_pct)
        print(f"{shape.name}: {len(changes)} stretch(es) where the advised feed differs by more than "
              f"{args.threshold_pct:g} % of F (B - A)")
        for c in changes:
            print(f"  s = {c.s_start_mm:.3f} .. {c.s_end_mm:.3f} mm: up to {c.max_diff_pct:+.3f} % "
                  f"at s = {c.at_s_mm:.3f} mm")
    return 0
