"""The designer as a local web app: served on 127.0.0.1 on a free port, one fresh document per
browser tab (each reads the file itself; saving checks the disk, so two tabs never overwrite each
other unasked)."""

from __future__ import annotations

import socket
from collections.abc import Callable


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start(make_layout: Callable, port: int | None = None):
    """A Bokeh server (started, not yet looping) with ``make_layout()`` as the page of each new
    session, on 127.0.0.1:``port`` (default: a free one); its address is :func:`address`."""
    import panel as pn

    from fuzzyfeed.errors import InputError

    chosen = port
    port = port or free_port()
    try:
        server = pn.serve({"/": make_layout}, port=port, address="127.0.0.1", show=False, start=False,
                          title="fuzzyfeed rule designer", verbose=False,
                          websocket_origin=[f"127.0.0.1:{port}", f"localhost:{port}"])
    except OSError as exc:
        raise InputError(f"--port {chosen or port}: cannot listen on 127.0.0.1:{port} "
                         f"({exc.strerror or exc})") from None
    server.start()
    return server


def address(server) -> str:
    """The page's URL."""
    return f"http://127.0.0.1:{server.port}/"
