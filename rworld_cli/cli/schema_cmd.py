"""rworld schema"""

from __future__ import annotations

import sys

import click

from ..errors import UserError
from .common import EXIT_CHECK_FAILED, emit_json, handle_errors, json_option, output_option


@click.command()
@output_option(
    "Directory to write the schemas into.", folder=True, name="output", default="schemas"
)
@click.option(
    "--check",
    is_flag=True,
    help="Write nothing; exit 1 if the files in the directory are missing or stale.",
)
@click.option(
    "--where",
    is_flag=True,
    help="Print the folder of this rworld's schemas in your cache (written there first): "
    "the path every file rworld writes points its editor line at.",
)
@json_option
@handle_errors
def schema(output: str, check: bool, where: bool, json_output: bool) -> None:
    """Write the JSON Schemas of every file format: cell, poses, program, run, path, measurements.

    The schemas are generated from the same models that validate the files,
    so an editor that uses them (e.g. the YAML language server, via a
    '# yaml-language-server: $schema=../../schemas/cell.schema.json' line)
    completes and checks keys as you type.  Cells 'rworld import urdf' writes,
    and programs rworld plans, point at this rworld's own copy (--where), so
    their editor line is right in any folder.

    \b
    Examples:
      rworld schema                 # regenerate schemas/
      rworld schema --check         # in CI: fail when schemas/ is stale
      rworld schema --where         # where imported cells' editor lines point
    """
    from ..api import installed_schemas, stale_schemas, write_schemas

    if where:
        folder = installed_schemas()
        if folder is None:
            raise UserError(
                "no schema folder: the cache folder is refused or cannot be written (see the "
                "warning above; RWORLD_CACHE_DIR names another)"
            )
        if json_output:
            emit_json({"folder": str(folder)})
        else:
            click.echo(str(folder))
        return

    if check:
        stale = stale_schemas(output)
        if json_output:
            emit_json({"directory": output, "stale": stale, "up_to_date": not stale})
        elif stale:
            click.echo(
                f"stale schemas in {output}: {', '.join(stale)} (run 'rworld schema -o {output}')",
                err=True,
            )
        else:
            click.echo(f"ok: schemas in {output} are up to date")
        if stale:
            sys.exit(EXIT_CHECK_FAILED)
        return
    written = write_schemas(output)
    if json_output:
        emit_json({"written": [str(p) for p in written]})
    else:
        for p in written:
            click.echo(f"wrote {p}")
