"""The commands that stay running: `fabhal watch` (the live view) and `fabhal lsp` (the language server)."""

from __future__ import annotations

import argparse
import sys

from fabhal.cli.common import EXIT_OK, EXIT_USAGE


def run_watch(args: argparse.Namespace) -> int:
    import threading
    import time as clock

    from fabhal.watch.files import watch_files
    from fabhal.watch.server import LiveServer
    from fabhal.watch.session import LiveResult, LiveSession, SolveSettings

    if not args.file.is_file():
        print(f"fabhal: cannot watch {args.file}: no such file", file=sys.stderr)
        return EXIT_USAGE
    if args.no_gravity:
        print("fabhal: watch shows where the hack hangs: --no-gravity does not apply", file=sys.stderr)
        return EXIT_USAGE

    def report(result: LiveResult) -> None:
        print(f"{clock.strftime('%H:%M:%S')} {result.summary} ({result.elapsed_s:.2f} s)", flush=True)

    settings = SolveSettings(dict(args.define), args.seed, args.time_limit, args.two_step)
    session = LiveSession(args.file, settings, report)
    try:
        server = LiveServer(args.port, session, args.file.name)
    except OSError as exc:
        print(f"fabhal: cannot serve on 127.0.0.1:{args.port}: {exc.strerror}", file=sys.stderr)
        return EXIT_USAGE
    stop = threading.Event()
    watcher = threading.Thread(
        target=watch_files, args=(lambda: session.dependencies, session.changed, stop), daemon=True
    )
    print(f"watching {args.file} and its imports; live view at {server.url} (Ctrl-C stops)", flush=True)
    session.start()
    watcher.start()
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        stop.set()
        session.stop()
        server.server_close()
    return EXIT_OK


def run_lsp(args: argparse.Namespace) -> int:
    try:
        from fabhal.lsp.server import main as serve
    except ImportError:
        print("fabhal: the language server needs pygls: pip install 'fabhal[lsp]'", file=sys.stderr)
        return EXIT_USAGE
    serve()
    return EXIT_OK
