"""bhr status: ask the actuator board for its current codes and faults."""
from __future__ import annotations

import json

import click

from bhr.cli._common import check_writable, guarded
from bhr.cli._link import link_options, link_settings

_MOTION = {0: "rest", 3: "tilt +x", 6: "tilt +y", 12: "tilt -x", 9: "tilt -y", 15: "lift"}


@click.command()
@link_options()
@click.option("--json", "json_path", default=None, metavar="PATH|-",
              help='Write {"codes": [...], "faults": [...]} to PATH (\'-\': stdout only).')
@guarded
def status(json_path, **link_kw):
    """Show the codes on the board's outputs (module 1 = base first) and its faults.

    Faults: silence (the host fell silent and everything was switched off;
    new codes or stop-all clear it), overheat:mK (a wire of module K reached
    the thermal limit; cleared by stop-all), cooling:mK (a wire of module K
    is cooling down after the limit or power-up; the module is held off
    while its code needs that wire), early:mK (module K was asked to
    energise a wire that had not relaxed yet and was held off; cleared by
    stop-all), reset (the board restarted, keeping its wires' temperatures;
    cleared by stop-all), flood (the board dropped replies because requests
    came faster than the line could answer; cleared by stop-all).
    A reply the board could not have sent (an unstable code, 0 modules,
    contradicting flags) is refused in one line, exit status 1.
    With --robot FILE the file's [link] table gives the port, baud rate and
    module order (codes are shown in module order).

    \b
        bhr status --port /dev/ttyUSB0 --json -
    """
    from bhr.output._atomic import write_json
    from bhr.model._codes import actuators
    from bhr._hardware.link import BoardLink

    check_writable(json_path, "JSON")
    port, link_args = link_settings(link_kw)
    with BoardLink(port, **link_args) as link:
        doc = link.status()
    if json_path == "-":
        click.echo(json.dumps(doc))
        return
    if json_path:
        write_json(json_path, doc)
    click.echo(f"board on {port}: {len(doc['codes'])} modules; faults: {', '.join(doc['faults']) or 'none'}")
    if "silence" in doc["faults"]:
        click.echo("silence: the host fell silent for longer than the board's silence timeout, so the board "
                   "switched every actuator off (as it does after a stream or 'follow --port --at-end hold' "
                   "ends); new codes or stop-all clear it")
    click.echo(f"{'module':<8}{'code':>5}  {'actuators':<10}{'motion'}")
    for i, code in enumerate(doc["codes"], start=1):
        acts = "+".join(str(a) for a in actuators(code)) or "-"
        click.echo(f"{'m' + str(i):<8}{code:>5}  {acts:<10}{_MOTION.get(code, '?')}")
