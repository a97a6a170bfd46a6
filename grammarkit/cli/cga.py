"""`grammarkit import-cga`: translate a CityEngine CGA rule file into a .grammar file."""
from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import click


@click.command("import-cga")
@click.argument("file", type=click.Path(path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="the .grammar file to write (default: FILE with the suffix .grammar; for a "
              "project folder or an .rpk, NAME.grammar in the current folder)")
@click.option("--rule", default=None,
              help="the rule file of a project or package to translate (default: its only one, "
              "or the one its compiled rule names)")
@click.option("--style", default=None,
              help="the CGA style to translate (default: the Default style)")
@click.option("--extract-to", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="where an .rpk is unpacked (default: NAME.rpk.d beside the output grammar); the "
              "grammar's asset_dir lines point there")
@click.option("--strict", is_flag=True, help="treat every warning as an error (nothing is written)")
@click.option("--report", "report_path", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="write the per-construct report (JSON) here")
@click.option("--force", is_flag=True,
              help="write the grammar even if it does not pass `grammarkit check`")
@click.option("--missing-assets", type=click.Choice(["keep", "drop", "error"]), default="keep",
              show_default=True,
              help="i() of an asset that is not found. keep: a file still missing while deriving "
              "leaves its shape out with a warning, as CityEngine does; drop: left out at import "
              "with a warning; error: the derivation stops at the missing file")
@click.option("--asset-dir", "asset_dirs", multiple=True,
              type=click.Path(file_okay=False, path_type=Path),
              help="another folder to look for assets in (repeatable)")
@click.option("--quiet", "-q", is_flag=True, help="print errors and the summary only, no warnings")
def import_cga_command(file: Path, output: Path | None, rule: str | None, style: str | None,
                       extract_to: Path | None, strict: bool, report_path: Path | None, force: bool,
                       missing_assets: str, asset_dirs: tuple[Path, ...], quiet: bool) -> None:
    """Translate the CGA rule FILE into grammarkit's language.

    FILE is a .cga file (inside a CityEngine project or not), a CityEngine project folder
    (rules/ + assets/) or a rule package (.rpk). Assets are looked up as CityEngine does (the
    rule file's folder, the project's assets/, imported projects), and the grammar's
    `asset_dir` lines let `grammarkit derive` find them from any working folder.

    Every CGA construct that is approximated or left out is reported as
    `file:line:col: warning: ...` with the CGA line. The grammar is written only if it passes
    `grammarkit check` (or with --force); exit status 1 if nothing was written.
    """
    from ..cga import translate_cga
    from ..cga.project import ProjectError, open_input
    from ..fileio import atomic_output, make_parent
    from ..run.writer import check_outputs

    packaged = file.is_dir() or file.suffix.lower() == ".rpk"
    out = output or (Path(file.resolve().name).with_suffix(".grammar") if packaged else file.with_suffix(".grammar"))
    # a CGA file named x.grammar, or -o/--report naming it or each other, would be overwritten
    check_outputs({"-o": out, "--report": report_path}, inputs=[file] if file.is_file() else [])
    if file.suffix.lower() == ".rpk" and extract_to is None:
        extract_to = out.resolve().parent / (file.name + ".d")
    try:
        project = open_input(file, rule=rule, extract_to=extract_to)
    except ProjectError as exc:
        click.echo(f"error: {exc}", err=True)
        sys.exit(1)
    if project.extracted_to is not None:
        click.echo(f"unpacked {file} to {project.extracted_to}", err=True)
    result = translate_cga(project.rule_file, output=out, asset_dirs=asset_dirs,
                           missing_assets=missing_assets, project=project, style=style)
    if strict:
        result.diagnostics = [dataclasses.replace(d, severity="error") if d.severity == "warning" else d
                              for d in result.diagnostics]
    for d in result.diagnostics:
        if quiet and d.severity != "error":
            continue
        click.echo(result.format(d), err=True)
    for line in result.report.check_errors[:5]:
        click.echo(line, err=True)
    rep = result.report
    missing = [a["path"] for a in rep.assets if a["found"] is False]
    if missing:
        click.echo(f"assets not found ({len(missing)}): {', '.join(missing)}", err=True)
    summary = (f"{rep.total} constructs: {rep.translated} translated, {rep.warned} warned "
               f"({rep.count('approximated')} approximated, {rep.count('dropped')} dropped)"
               + (f", {len(rep.imported)} warned in imported files" if rep.imported else ""))
    if report_path is not None:
        make_parent(report_path)  # as derive does for -o: a new output folder is made
        with atomic_output(report_path) as tmp:
            tmp.write_text(json.dumps(rep.to_json(), indent=2) + "\n", encoding="utf-8")
    if strict and any(d.severity == "error" for d in result.diagnostics) and result.text is not None:
        click.echo(f"{summary}; nothing written (--strict: warnings are errors)", err=True)
        sys.exit(1)
    if result.text is None or (not result.ok and not force):
        click.echo(f"{summary}; nothing written", err=True)
        sys.exit(1)
    make_parent(out)
    with atomic_output(out) as tmp:
        tmp.write_text(result.text, encoding="utf-8", newline="\n")
    note = "" if result.ok else " (with --force: it does not pass `grammarkit check`)"
    click.echo(f"{summary}; wrote {out}{note}", err=True)
