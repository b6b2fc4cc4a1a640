"""``uvnav script FILE [--headless]``: replay a console script (language: docs/CONSOLE.md).

In the visible console the script drives the UI while you watch; the console stays open when it
ends. With ``--headless`` no terminal is used, the pace is "as fast as possible", ``sleep``
lines are skipped and the hardcopies are written; the exit status is 0 on success, 1 if a line
failed, 2 for bad input (script or configuration).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from engine.api import InputError
from uvnav_tui.cli.console import resolve_config

HEADLESS_SIZE = (100, 30)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uvnav script``."""
    p = argparse.ArgumentParser(prog="uvnav script", description=__doc__.splitlines()[0])
    p.add_argument("script", help="script file (one console action per line)")
    p.add_argument("--headless", action="store_true",
                   help="run without a terminal, as fast as possible, writing the hardcopies")
    p.add_argument("--config", help="run configuration TOML (default: data/DEMO.toml)")
    p.add_argument("--hardcopy-dir", default="hardcopy",
                   help="directory for the hardcopies (default: ./hardcopy)")
    p.add_argument("--dev", action="store_true", help="start in developer mode")
    p.add_argument("--no-out", action="store_true", help="write no .OUT log")
    return p


def run_script(argv: list[str]) -> int:
    """Run a script in the console; returns the exit status."""
    args = build_parser().parse_args(argv)
    from uvnav_tui.script import ScriptError, ScriptRunner, load_script

    try:
        steps = load_script(Path(args.script))
        cfg, data = resolve_config(args.config)
    except ScriptError as exc:
        print(f"uvnav script: {args.script}: {exc}", file=sys.stderr)
        return 2
    except (InputError, OSError) as exc:
        print(f"uvnav script: {exc}", file=sys.stderr)
        return 2
    from textual.pilot import Pilot

    from uvnav_tui.app import UVNAVApp

    app = UVNAVApp(cfg, dev_mode=args.dev, hardcopy_dir=Path(args.hardcopy_dir),
                   pace_override="fast" if args.headless else None, hold=True,
                   lop_policy="yes", write_logs=not args.no_out, data=data)
    failure: list[str] = []

    async def drive(pilot: Pilot[None]) -> None:
        runner = ScriptRunner(pilot, headless=args.headless)
        try:
            if not await runner.run_or_quit(steps):
                return  # the console was quit (Ctrl+Q, or the script's own quit)
        except ScriptError as exc:
            failure.append(str(exc))
            if args.headless:
                app.stop_run()
                app.exit()
            else:
                runner.release_hold()
                app.say(f"Script stopped at {exc}")
            return
        if args.headless:
            app.stop_run()
            app.exit()
        else:
            runner.release_hold()
            app.say(f"Script {Path(args.script).name} finished")

    if args.headless:
        app.run(headless=True, size=HEADLESS_SIZE, auto_pilot=drive)
    else:
        app.run(auto_pilot=drive)
    for svg, txt in app.hardcopies:
        print(f"hardcopy {svg} {txt.name}")
    if failure:
        print(f"uvnav script: {args.script}: {failure[0]}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(run_script(sys.argv[1:]))
