"""``fuzzyfeed design [TABLE] [--shape SHAPE | --program FILE] [--machine M]``: the interactive rule
designer as a local web app (127.0.0.1, a free port), opened in the browser."""

from __future__ import annotations

import argparse

from fuzzyfeed.cli._common import point_count, positive_float


def register(sub) -> None:
    p = sub.add_parser(
        "design", help="edit a rule table interactively in the browser",
        description="Serve the rule designer on 127.0.0.1 (a free port unless --port) and open it "
                    "in the browser: the membership functions of every variable (drag a breakpoint "
                    "or type it), the rule grid, the control surface (heatmap and 3-D) and the "
                    "advice on a path, redrawn after every edit; rules check's validation next to "
                    "the field that breaks it; undo/redo; save (comments kept, the rules diff "
                    "against the file on disk shown first, never over a file changed on disk "
                    "without asking) and export to FCL, FLL and .fis. TABLE is a shipped name "
                    "(default: paper; saved to ./NAME.toml) or a .toml file. Ctrl-C stops it.")
    p.add_argument("table", nargs="?", default=None, metavar="TABLE")
    path = p.add_mutually_exclusive_group()
    path.add_argument("--shape", default=None, metavar="SHAPE",
                      help="path to advise: a shipped shape or any file advise reads, with its "
                           "#SELECTOR (default: trident)")
    path.add_argument("--program", default=None, metavar="FILE",
                      help="path to advise: a cut of a G-code program on its exact geometry "
                           "(FILE = the first cut, FILE#N = cut N)")
    p.add_argument("--points", type=point_count, default=2000, metavar="N",
                   help="sample points of --shape (default: %(default)s)")
    p.add_argument("--feed-mm-min", type=positive_float, default=6000.0, metavar="F",
                   help="maximum feed the advice is a fraction of, mm/min (default: %(default)g)")
    p.add_argument("--port", type=int, default=None, metavar="PORT",
                   help="port on 127.0.0.1 (default: a free one)")
    p.add_argument("--no-browser", action="store_true", help="only print the address")
    from fuzzyfeed.cli._machine import add_machine_arguments

    add_machine_arguments(p)
    p.set_defaults(run=run_design)


def run_design(args: argparse.Namespace) -> int:
    import webbrowser

    from fuzzyfeed.base.outputs import Terminated
    from fuzzyfeed.designer import server
    from fuzzyfeed.designer.app import Designer, load_path
    from fuzzyfeed.designer.document import Document
    from fuzzyfeed.errors import InputError

    from fuzzyfeed.cli._machine import machine_from_args

    machine = machine_from_args(args)
    Document(args.table)            # a bad table is refused here, in one line, before serving
    if args.port is not None and not 1 <= args.port <= 65535:
        raise InputError(f"--port {args.port}: must be 1 to 65535")
    shape = args.shape if args.shape or args.program else "trident"
    samples, name = load_path(shape, args.program, args.points)

    def page():
        return Designer(args.table, samples=samples, path_name=name, feed_mm_min=args.feed_mm_min,
                        machine=machine).panel()

    srv = server.start(page, args.port)
    url = server.address(srv)
    print(f"fuzzyfeed design: {url}  (Ctrl-C stops it)", flush=True)
    if not args.no_browser:
        webbrowser.open(url)
    why = "Ctrl-C"            # Panel's SIGINT handler stops the loop
    try:
        srv.io_loop.start()
    except Terminated as exc:
        why = exc.signal_name
    finally:
        srv.stop()
    print(f"fuzzyfeed design: stopped ({why})", flush=True)
    return 0
