"""``fuzzyfeed rules show|check|set|surface``: look at, validate, edit and draw rule tables."""

from __future__ import annotations

import argparse
from pathlib import Path

from fuzzyfeed.errors import RuleTableError


def register(sub) -> None:
    p = sub.add_parser(
        "rules", help="show, check, edit or draw a fuzzy rule table",
        description="Rule tables of the fuzzy advisor (seed 002): TOML files with the universes, "
                    "the term breakpoints, WS, the Dk clip, the filter size, a feed floor and the "
                    "rule grid. TABLE is a shipped name (default: paper) or a .toml file.")
    rs = p.add_subparsers(dest="rules_command", metavar="ACTION", required=True)

    show = rs.add_parser("show", help="print the grid, the terms and the settings",
                         description="Print a rule table. --format csv/tsv prints only the grid for "
                                     "a spreadsheet; --format toml prints the file itself (with its "
                                     "comments), e.g. to start your own table: "
                                     "`fuzzyfeed rules show --format toml > mine.toml`; --format fcl "
                                     "exports IEC 61131-7 FCL (MIN/MIN/MAX, COG).")
    show.add_argument("table", nargs="?", default=None, metavar="TABLE")
    show.add_argument("--format", choices=("text", "csv", "tsv", "toml", "fcl"), default="text",
                      help="output format (default: %(default)s)")
    show.set_defaults(run=run_show)

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
    from fuzzyfeed.fuzzy.rules import grid_text

    lines = [f"rule table {table.name!r}" + (f"  ({table.path})" if table.path else "")]
    if table.source:
        lines.append(f"source: {table.source}")
    lines.append(f"features: WS = {table.window_points} points, Dk clip = {table.dk_clip_1_mm:g} 1/mm, "
                 f"average filter M = {table.filter_points} points, feed floor = "
                 f"{table.feed_floor_pct:g} %")
    for var, unit in ((table.curvature, "1/mm"), (table.curvature_variation, "normalised"),
                      (table.feed, "% of max feed")):
        lo, hi = var.universe
        terms = "  ".join(f"{t.label}=[{', '.join(f'{x:g}' for x in t.points)}]" for t in var.terms)
        lines.append(f"{var.name} [{lo:g}, {hi:g}] ({unit}): {terms}")
    lines.append("")
    lines.append("rules: IF curvature is ROW AND curvature_variation is COLUMN THEN feed is CELL")
    lines.append(grid_text(table).rstrip("\n"))
    return "\n".join(lines)


def run_show(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rules import grid_text, load_rule_table, resolve_rules_path

    if args.format == "toml":
        path = resolve_rules_path(args.table)
        load_rule_table(path)   # only print valid tables
        print(path.read_text(encoding="utf-8"), end="")
        return 0
    table = load_rule_table(args.table)
    if args.format == "fcl":
        from fuzzyfeed.fuzzy.rules import table_to_fcl

        print(table_to_fcl(table), end="")
    elif args.format in ("csv", "tsv"):
        print(grid_text(table, sep="," if args.format == "csv" else "\t"), end="")
    else:
        print(_describe(table))
    return 0


def run_check(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rules import load_rule_table

    for spec in args.tables or [None]:
        table = load_rule_table(spec)
        nk, nd = len(table.curvature.terms), len(table.curvature_variation.terms)
        print(f"ok: {table.path}: table {table.name!r}, {nk * nd} rules ({nk} x {nd}), "
              f"{len(table.feed.terms)} feed terms")
    return 0


def run_set(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rules import set_cell

    path = Path(args.file)
    if not path.is_file():
        raise RuleTableError(f"{path}: no such file; `rules set` edits a file (copy a shipped table "
                             "first: fuzzyfeed rules show paper --format toml > mine.toml)")
    table = set_cell(path, args.row, args.column, args.label)
    print(f"{path}: rule (curvature {args.row}, curvature_variation {args.column}) -> {args.label}; "
          f"table {table.name!r} is valid")
    return 0


def run_surface(args: argparse.Namespace) -> int:
    from fuzzyfeed.fuzzy.rules import load_rule_table
    from fuzzyfeed.plot import plot_rule_surface

    table = load_rule_table(args.table)
    plot_rule_surface(table, args.output)
    print(f"wrote {args.output}")
    return 0
