"""Options shared by the commands that talk to the actuator board: port, baud, timeout, retries."""
from __future__ import annotations

from typing import Any, Callable

import click

from bhr.cli._options import FiniteRange, PlainIntRange, stack_options

#: Fastest baud rate accepted (USB serial adapters top out at a few Mbaud).
MAX_BAUD = 4_000_000

PORT_HELP = "Serial device (/dev/ttyUSB0, COM3, /dev/pts/N), socket://host:port or loop://."


def link_options(port_help: str = PORT_HELP, robot: bool = True) -> Callable[[Any], Any]:
    """--port, --baud, --timeout, --retries (and --robot for the file's [link] table)."""
    opts = [
        click.option("--port", default=None, metavar="PORT", help=port_help),
        click.option("--baud", default=None, metavar="BAUD", type=PlainIntRange(min=50, max=MAX_BAUD),
                     help="Baud rate [the robot file's link.baudrate, else 115200]."),
        click.option("--timeout", default=0.25, show_default=True, metavar="S",
                     type=FiniteRange(min=0, min_open=True, max=60), help="Seconds to wait for each answer."),
        click.option("--retries", default=3, show_default=True, metavar="N", type=PlainIntRange(min=0, max=100),
                     help="Extra tries for a frame that gets no answer or arrives damaged."),
    ]
    if robot:
        opts.insert(0, click.option("--robot", "robot_file", default=None, metavar="FILE",
                                    help="Robot description (.toml or .json) whose [link] table gives the port, "
                                         "baud rate and module order; options given here override it."))
    return stack_options(*opts)


def link_settings(kwargs: dict[str, Any], need_port: bool = True, use_file_port: bool = True, hint: str = ""):
    """Pop the link options from ``kwargs``; return (port, BoardLink keyword arguments).

    The robot file's ``[link]`` table (if ``--robot`` was given) supplies the
    defaults: port (when ``use_file_port``), baud rate and module order.
    """
    from bhr._settings.errors import BhrError
    from bhr._hardware.link import DEFAULT_BAUD

    path = kwargs.pop("robot_file", None)
    port, baud = kwargs.pop("port", None), kwargs.pop("baud", None)
    timeout, retries = kwargs.pop("timeout"), kwargs.pop("retries")
    order = None
    if path is not None:
        from bhr.model._robotfile import load_robot_file

        link = load_robot_file(path).link
        if port is None and use_file_port:
            port = link.port
        baud = link.baudrate if baud is None else baud
        order = link.module_order
    if port:
        from bhr.model._robotfile import check_file_port

        port = check_file_port(str(port), "--port")  # the same allow-list as a robot file's [link] port
    if need_port and not port:
        raise BhrError("--port is required: pass --port (e.g. --port /dev/ttyUSB0), or set port in the [link] "
                       "table of a --robot file" + hint)
    return port, {"baudrate": DEFAULT_BAUD if baud is None else baud, "timeout": timeout, "retries": retries,
                  "module_order": order}


def exit_interrupted(exc, total: int, unit: str) -> None:
    """After Ctrl-C, SIGTERM or SIGHUP while streaming (a bhr._hardware.link.StreamInterrupted): one line, and the
    signal's exit status (130 for Ctrl-C)."""
    from bhr.cli._interrupt import exit_status

    if exc.stopped:
        click.echo(f"Interrupted after {exc.sent} of {total} {unit}; sent stop-all, every actuator is off.", err=True)
    else:
        click.echo(f"Interrupted after {exc.sent} of {total} {unit}; stop-all failed ({exc.detail}); "
                   "the board switches off by itself after its silence timeout.", err=True)
    raise SystemExit(exit_status())


SCHEDULE_HELP = ("auto (the default, always one the board accepts): stretch each step to what the wires allow "
                 "(contraction and relaxation), never faster than --rate; rate: send at --rate after checking the "
                 "whole stream against the wires' thermal model (refused, before anything is sent, where the board "
                 "would fault).")


def schedule_option() -> Callable[[Any], Any]:
    return click.option("--schedule", type=click.Choice(["auto", "rate"]), default="auto", show_default=True,
                        help=SCHEDULE_HELP)


def at_end_option(default: str, when: str = "After the last row") -> Callable[[Any], Any]:
    """--at-end: the explicit last message of a stream (bhr._hardware.link.run_stream's at_end)."""
    return click.option("--at-end", "at_end", type=click.Choice(["stop", "hold"]), default=default,
                        show_default=True,
                        help=f"{when}: 'stop' sends stop-all (every actuator off); 'hold' sends a heartbeat and "
                             "leaves the last codes on until the board's silence timeout switches them off.")


def end_text(at_end: str) -> str:
    """What the stream's last message did, for the closing line."""
    if at_end == "hold":
        return ("holding the last codes (--at-end hold): the board switches them off after its silence timeout "
                "unless the host sends again, and then reports 'silence'")
    return "sent stop-all at the end (--at-end stop): every actuator is off"


def thermal_params(robot_file):
    """The robot file's [thermal] table (docs/thermal.md), or the default wire."""
    from bhr._hardware.thermal import DEFAULT_THERMAL

    if robot_file is None:
        return DEFAULT_THERMAL
    from bhr.model._robotfile import load_robot_file

    return load_robot_file(robot_file).thermal


def fault_printer(port: str) -> Callable[[int, list[str]], None]:
    """``on_fault`` for the link's Pacer: one line on stderr per fault the board raises, with module and step."""
    def show(step: int, names: list[str]) -> None:
        for name in names:
            kind, _, module = name.partition(":")
            where = f"module {module}, " if module else ""
            click.echo(f"Board fault: {where}step {step}: {kind} ({FAULT_TEXT.get(kind, 'see docs/protocol.md')})",
                       err=True)
    return show


FAULT_TEXT = {
    "overheat": "a wire reached the thermal limit; the module is off until it cools",
    "early": "a wire was asked to contract again before it had relaxed; the module is held off",
    "reset": "the board restarted",
    "flood": "the board dropped replies",
    "cooling": "the module is cooling down",
}
