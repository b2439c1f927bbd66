"""`hriplan ontology`: the ontology as a file for OWL tools (Protégé, owlready2, the OWL API)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from hriplan.cli.errors import clear_errors

ontology_app = typer.Typer(
    help="The ontology as a file for OWL tools: Turtle, RDF/XML or OWL/XML.",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@ontology_app.command("export")
@clear_errors
def export(
    fmt: Annotated[str, typer.Option("--format", help="ttl, rdfxml or owx (OWL/XML).")] = "ttl",
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the file here (else print it).")] = None,
    with_robots: Annotated[
        bool, typer.Option("--with-robots", help="Add the robot individuals (arms, joints, stopping data).")
    ] = False,
    alignment: Annotated[
        str | None, typer.Option("--alignment", help="Add an alignment to another ontology: soma (SOMA and DUL).")
    ] = None,
) -> None:
    """Print (or write) the ontology with its metadata and units, for OWL tools.

    \b
    Examples:
      hriplan ontology export --format rdfxml -o hriplan.owl       owlready2: get_ontology("hriplan.owl").load()
      hriplan ontology export --format owx --with-robots -o hriplan.owx
      hriplan ontology export --alignment soma -o hriplan-soma.ttl  imports SOMA-HOME and DUL
    """
    from hriplan.cli.outputs import file_output
    from hriplan.files import write_atomically
    from hriplan.ontology.export import export_ontology

    target = None if output is None else file_output(output)
    text = export_ontology(fmt, with_robots=with_robots, alignment=alignment)
    if target is None:
        sys.stdout.write(text)
    else:
        write_atomically(target, text)
        typer.echo(f"wrote {target}")
