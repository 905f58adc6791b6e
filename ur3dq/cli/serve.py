"""`ur3dq serve`: the cell's screen, a pendant in the browser (ur3dq.screen). The web stack is imported only when
the command runs, so `ur3dq --help` and every other command start without it."""
from __future__ import annotations

import secrets
import socket
from pathlib import Path

import click

from ur3dq.cli.app import NO_ROBOT_HINT, Settings, cli, emit_json
from ur3dq.cli.background_simulator import running_simulator_host
from ur3dq.cli.options import cell_option, display_options

DEFAULT_PORT = 8765
MIN_TOKEN_LENGTH = 12


@cli.command(short_help="The cell's screen in a browser: live arm, program, jog, run.")
@click.option("--port", type=click.IntRange(0, 65535), default=DEFAULT_PORT, show_default=True,
              help="TCP port of the page (0: any free port).")
@click.option("--bind", default="127.0.0.1", show_default=True, metavar="ADDRESS",
              help="Address to listen on. Anything but loopback lets other machines open the page: then --token "
                   "is required.")
@click.option("--token", envvar="UR3DQ_SCREEN_TOKEN", metavar="SECRET",
              help=f"A secret (≥ {MIN_TOKEN_LENGTH} characters) every page must bring; it is printed in the URL "
                   "(env UR3DQ_SCREEN_TOKEN). `--token new` makes one up.")
@cell_option
@display_options
@click.pass_obj
def serve(settings: Settings, port: int, bind: str, token: str | None, cell_path: Path | None) -> None:
    """Serve the cell's screen: a live 3D arm, the program, teach, jog, check and run, in a browser.

    One page at a time moves the arm; others watch read-only until they take control. Every motion is planned and
    path-checked as run-poses does, and stops when the controlling page closes. Pages start in the units --deg and
    --mm choose (each page can change its own); --json prints the URL as JSON. Needs the screen's web stack:
    pip install 'ur3dq[screen]'. Ctrl-C stops the server (and any motion it started).

    \b
    Examples:
      ur3dq serve --deg --mm                        # http://127.0.0.1:8765/
      ur3dq serve --cell cell.json --port 8080
      ur3dq serve --bind 0.0.0.0 --token new        # reachable from a tablet
    """
    from ur3dq.screen.access import is_loopback

    if token == "new":
        token = secrets.token_urlsafe(18)
    if token is not None and len(token) < MIN_TOKEN_LENGTH:
        raise click.UsageError(f"--token must be at least {MIN_TOKEN_LENGTH} characters (or `--token new`)")
    if not is_loopback(bind) and token is None:
        raise click.UsageError(f"--bind {bind} lets other machines open the page and move the arm: give --token "
                               "SECRET (or `--token new`); the page's URL then carries it")
    try:
        import uvicorn

        from ur3dq.screen.server import ScreenServer, ServeConfig
        from ur3dq.screen.station import StationConfig
    except ImportError as error:
        raise click.UsageError(f"ur3dq serve needs the screen's web stack ({error.name} is missing): "
                               "pip install 'ur3dq[screen]'") from None
    from ur3dq.pathcheck import load_cell

    cell = load_cell(cell_path) if cell_path else None
    host = settings.host or running_simulator_host()
    station = StationConfig(host, settings.backend, settings.model, settings.store_path, cell, cell_path,
                            NO_ROBOT_HINT)
    listening = _listening_socket(bind, port)
    port = listening.getsockname()[1]
    server = ScreenServer(ServeConfig(station, bind, port, token, settings.units))
    url = _url(bind, port, token)
    click.echo(f"ur3dq serve: the cell's screen is at {url} "
               f"({'robot ' + host if host else 'no robot: ' + NO_ROBOT_HINT}; Ctrl-C stops it)", err=True)
    if settings.json:
        emit_json({"url": url, "bind": bind, "port": port, "token": token is not None, "robot": host,
                   "store": str(settings.store_path), "cell": str(cell_path) if cell_path else None})
    if not is_loopback(bind):
        click.echo(f"ur3dq serve: listening on {bind}: other machines can open the page with the token in its URL",
                   err=True)
    config = uvicorn.Config(server.app, log_level="warning", ws="websockets-sansio", lifespan="on", access_log=False)
    uvicorn.Server(config).run(sockets=[listening])


def _listening_socket(bind: str, port: int) -> socket.socket:
    """A socket bound to bind:port and listening; UsageError naming the port when it is taken."""
    family = socket.AF_INET6 if ":" in bind else socket.AF_INET
    listening = socket.socket(family, socket.SOCK_STREAM)
    listening.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        listening.bind((bind, port))
    except OSError as error:
        listening.close()
        raise click.UsageError(f"cannot listen on {bind}:{port}: {error.strerror or error}; choose another --port "
                               "or --bind") from None
    listening.listen(64)
    return listening


def _url(bind: str, port: int, token: str | None) -> str:
    """The page's URL as printed: the bind address (this machine's, for a wildcard bind) and the token."""
    where = "<this machine's address>" if bind in ("0.0.0.0", "::") else (f"[{bind}]" if ":" in bind else bind)
    return f"http://{where}:{port}/" + (f"?token={token}" if token else "")
