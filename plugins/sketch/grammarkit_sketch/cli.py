"""The commands: `grammarkit recognize`, `grammarkit sketch-session`, `grammarkit train sketch`.

Only click is imported here; everything heavy (torch, the renderer, scipy) is imported when a
command runs, so `grammarkit --help` and `grammarkit plugins` stay fast.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

METHODS = ("pattern", "greedy", "metropolis")  # refine.METHODS (refine.py is not light)
SCORES = ("chamfer", "paper", "pen")  # refine.SCORES


def _echo_json(data: Any) -> None:
    from grammarkit.jsonable import to_jsonable

    click.echo(json.dumps(to_jsonable(data), indent=2))


def _one_thread() -> None:
    """The networks are small: one thread is as fast and does not fight other processes."""
    from .nets import require_torch

    require_torch().set_num_threads(1)


def stderr_progress() -> Any:
    """A rich progress display on stderr (stdout keeps the summary or the JSON); transient, so
    a terminal is left with the summary only, and silent when stderr is not a terminal."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    console = Console(stderr=True)
    return Progress(SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(),
                    MofNCompleteColumn(), TimeElapsedColumn(), console=console,
                    transient=True, disable=not console.is_terminal)


def _range(info: Any, name: str) -> str:
    p = next(p for p in info.params if p.name == name)
    return f"[{p.lo:g}, {p.hi:g}]"


def print_recognition(r: Any, library: Any, source: str) -> None:
    info = library.snippets[r.snippet]
    click.echo(f"{source}: {r.object_type} sketch")
    for c in r.top:
        mark = "  <- recognised" if c.snippet == r.snippet else ""
        same = f"  (draws like {', '.join(c.same_drawing)})" if c.same_drawing else ""
        click.echo(f"  {c.snippet:<18} {c.probability:6.3f}{same}{mark}")
    if r.snippet not in [c.snippet for c in r.top]:
        click.echo(f"  {r.snippet:<18} {r.probability:6.3f}  <- chosen with --snippet")
    if r.page_turn:
        click.echo(f"the page was turned {r.page_turn:+.1f} deg: read turned back")
    if r.redraw:
        click.echo(f"not sure (probability {r.probability:.2f}, below {r.redraw_below:.2f}): redraw "
                   "the sketch, or choose the snippet with --snippet NAME")
    if info.params:
        click.echo(f"parameters of {r.snippet}:")
        width = max(len(p.name) for p in info.params)
        for p in info.params:
            note = "" if p.name in r.estimated else (
                "  (not visible in a sketch: default)" if p.name in r.hidden else "  (default)")
            click.echo(f"  {p.name:<{width}} = {float(r.values[p.name]):<8.4g} in {_range(info, p.name)}{note}")
    ref = (f"; {r.refine_steps} {r.method} refinement step(s), {r.evaluations} renders"
           if r.refine_steps else "; no refinement (--refine N to refine)")
    click.echo(f"match score: {r.score:.3f} ({r.score_kind}; network estimate {r.network_score:.3f}{ref})")
    tm = r.timings
    click.echo(f"time: {tm['total']:.0f} ms (read {tm['load']:.0f}, classify {tm['classify']:.1f}, "
               f"regress {tm['regress']:.1f}, score {tm['score']:.1f}, refine {tm['refine']:.0f})")
    click.echo(r.use_line())
    sets = " ".join(f"--set {s}" for s in r.set_options())
    if sets:
        click.echo(sets)


@click.command("recognize")
@click.argument("sketch", type=click.Path(dir_okay=False, path_type=Path), required=False)
@click.option("--type", "object_type", required=True, help="Object type of the sketch (Mass, Roof, ...).")
@click.option("--library", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Snippet library (default: the one the models were trained on).")
@click.option("--models", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Models file from `grammarkit train sketch` (default: the shipped weights).")
@click.option("--refine", "refine_steps", type=click.IntRange(0, 10_000), default=0, show_default=True,
              help="Refinement steps (sweeps) against the sketch's distance transform.")
@click.option("--method", type=click.Choice(METHODS), default="pattern", show_default=True,
              help="Refinement search: line scans + compass search (pattern), the public code's "
                   "greedy coordinate search, or the paper's Metropolis-Hastings.")
@click.option("--score", type=click.Choice(SCORES), default="chamfer", show_default=True,
              help="Refinement score: truncated symmetric chamfer distance, the same with the "
                   "proposals drawn in the sketch's own line width (pen), or the paper's "
                   "exp(-RMS(D(render) - D(sketch))).")
@click.option("--view-range", type=click.FloatRange(0, 10), default=3.0, show_default=True,
              help="Degrees the refinement may turn the view (pitch and yaw) to match a sketch "
                   "drawn in slightly wrong perspective; 0: the stage camera only.")
@click.option("--prior/--no-prior", default=True, show_default=True,
              help="The default refinement (pattern) weighs the score with a Gaussian prior around "
                   "the network's estimate (as wide as the regressor's validation error); "
                   "--no-prior searches the score alone.")
@click.option("--rectify/--no-rectify", default=True, show_default=True,
              help="Undo a turn of the page (a few degrees) on stages seen straight on (facades, "
                   "floors, windows) before recognising; --no-rectify reads the drawing as it is "
                   "(the paper).")
@click.option("--rerank/--no-rerank", default=False, show_default=True,
              help="With --refine: fit each likely snippet (probability >= 0.05, top 3) to the "
                   "sketch and answer the one whose refined model matches best.")
@click.option("--snippet", default=None, help="Skip the classifier: estimate this snippet's parameters.")
@click.option("--preview", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the sketch with the recognised model drawn over it (PNG).")
@click.option("--canvas", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the type's empty canvas (where to draw) and exit.")
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the Metropolis-Hastings search.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def recognize_command(sketch: Path | None, object_type: str, library: Path | None, models: Path | None,
                      refine_steps: int, method: str, score: str, view_range: float, prior: bool,
                      rectify: bool, rerank: bool, snippet: str | None, preview: Path | None,
                      canvas: Path | None, seed: int, as_json: bool) -> None:
    """Recognise the snippet and its parameters in a sketch of one object type.

    Prints the top 3 snippets with probabilities, the parameter values, the match score and
    a `use` line with `--set` values that reproduce it (Nishida et al. 2016).
    """
    from .recognizer import get_recognizer

    _one_thread()
    with stderr_progress() as bar:
        bar.add_task("loading the models", total=None)
        rec = get_recognizer(models, library)
    t = rec.library.check_type(object_type)
    if canvas is not None:
        rec.canvas(t, canvas)
        w, h = rec.models.type_model(t).stage.canvas_size()
        click.echo(f"wrote {canvas}: the {t} canvas (aspect {w}:{h}); draw on it at any resolution")
        if sketch is None:
            return
    if sketch is None:
        raise click.UsageError("give a SKETCH image (or --canvas OUT.png)")
    with stderr_progress() as bar:
        bar.add_task(f"recognising {sketch}" + (f" ({refine_steps} refinement steps)" if refine_steps else ""),
                     total=None)
        r = rec.recognize(sketch, t, refine_steps=refine_steps, method=method, snippet=snippet, seed=seed,
                          score=score, view_range=view_range, prior=prior, rectify=rectify, rerank=rerank)
        if preview is not None:
            rec.preview(sketch, r, preview)
    if as_json:
        data = {"sketch": str(sketch), **r.to_dict()}
        if preview is not None:
            data["preview"] = str(preview)
        _echo_json(data)
        return
    print_recognition(r, rec.library, str(sketch))
    if preview is not None:
        click.echo(f"wrote {preview}")


@click.command("sketch-session")
@click.argument("session", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The generated grammar (.grammar).")
@click.option("--library", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Snippet library (default: the one the models were trained on).")
@click.option("--models", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Models file (default: the shipped weights).")
@click.option("--refine", "refine_steps", type=click.IntRange(0, 10_000), default=None,
              help="Refinement steps for every stage (overrides the session file).")
@click.option("--method", type=click.Choice(METHODS), default=None, help="Refinement search.")
@click.option("--canvases", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Write each stage's canvas with its strokes and recognised snippet to this folder.")
@click.option("--json", "as_json", is_flag=True, help="Print the stages as JSON.")
def sketch_session_command(session: Path, output: Path, library: Path | None, models: Path | None,
                           refine_steps: int | None, method: str | None, canvases: Path | None,
                           as_json: bool) -> None:
    """Turn a sketching session (strokes per object type) into one grammar for the building.

    Stages run coarse to fine (mass, roof, facade, floor, window, ledge); stages not sketched
    get the library's default snippet. The output passes `grammarkit check` and derives.
    """
    import grammarkit
    from grammarkit.fileio import atomic_output

    from .session import Session

    _one_thread()
    with stderr_progress() as bar:
        task = bar.add_task("loading the models", total=None)

        def stage_done(t: str, done: int, total: int) -> None:
            bar.update(task, description=f"recognising {t}" if t else "writing the grammar",
                       completed=done, total=total)

        s = Session.from_file(session, models=models, library=library, refine=refine_steps,
                              method=method, canvases=canvases, progress=stage_done)
        text = s.grammar_text(output.resolve().parent, source=session.name)
    problems = [d for d in grammarkit.check(text) if d.severity == "error"]
    if problems:  # a bug, not a user error: say so rather than write a broken file
        raise click.ClickException("the generated grammar does not check: " + problems[0].message)
    with atomic_output(output) as tmp:
        tmp.write_text(text, encoding="utf-8")
    if as_json:
        _echo_json({"output": str(output), "lot": list(s.lot),
                    "stages": {t: r.recognition.to_dict() for t, r in s.stages.items()},
                    "defaults": {t: sn for t, (sn, _) in s.choices().items() if t not in s.stages}})
        return
    for t in s.library.types:
        if t in s.stages:
            r = s.stages[t].recognition
            vals = ", ".join(f"{k}={float(r.values[k]):.3g}" for k in r.estimated)
            click.echo(f"{t:<8} {r.snippet:<16} p={r.probability:.2f} score={r.score:.2f}  {vals}")
        else:
            click.echo(f"{t:<8} {s.library.default_for(t):<16} (default: not sketched)")
    click.echo(f"wrote {output}")
    if canvases is not None:
        click.echo(f"wrote the stage canvases to {canvases}/")


@click.command("sketch")
@click.option("--library", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="The snippet library to learn (every snippet attr needs an @range).")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Models file to write (e.g. sketch.models).")
@click.option("--samples", type=click.IntRange(20, 1_000_000), default=1200, show_default=True,
              help="Training renders per snippet (10% held out for validation).")
@click.option("--classifier-epochs", type=click.IntRange(1, 1000), default=14, show_default=True)
@click.option("--regressor-epochs", type=click.IntRange(1, 1000), default=30, show_default=True)
@click.option("--style", type=click.Choice(("sketchy", "plain", "augmented")), default="sketchy",
              show_default=True,
              help="Training drawings: hand-drawn-looking (the paper's), exact lines (Table 3), or "
                   "hand-drawn with the page turned and the view off by up to 6 degrees and some "
                   "strokes broken off (augmented).")
@click.option("--types", default=None, help="Comma-separated object types to train (default: all).")
@click.option("--classifiers-only", is_flag=True,
              help="Train the snippet classifiers only (e.g. to compare training styles).")
@click.option("--classifier-input", default="as-drawn", show_default=True,
              help="What the classifiers read: as-drawn (the paper) or centre-lines (every line "
                   "thinned to one pixel, whatever the pen), for all types or per type as "
                   "TYPE=KIND,... (types not named: as-drawn).")
@click.option("--cache", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Folder caching the rendered training sets (default: ~/.cache/grammarkit/sketch).")
@click.option("--no-cache", is_flag=True, help="Render the training sets without reading or writing the cache.")
@click.option("--threads", type=click.IntRange(1, 64), default=1, show_default=True, help="torch threads.")
@click.option("--workers", type=click.IntRange(1, 64), default=1, show_default=True,
              help="Processes rendering the training sets (results do not depend on it).")
@click.option("--seed", type=int, default=0, show_default=True)
def train_sketch_command(library: Path, output: Path, samples: int, classifier_epochs: int,
                         regressor_epochs: int, style: str, types: str | None, classifiers_only: bool,
                         classifier_input: str, cache: Path | None,
                         no_cache: bool, threads: int, workers: int, seed: int) -> None:
    """Train the sketch recognizer of a snippet library: one classifier per object type and one
    parameter regressor per snippet, on renders of snippets with parameters sampled in their
    ranges (Nishida et al. 2016)."""
    from rich.console import Console

    from grammarkit.fileio import check_outputs

    from .dataset import DEFAULT_CACHE
    from .models import save_models
    from .training import TrainConfig, train

    check_outputs({"-o": output})  # a device, FIFO or socket is refused before minutes of training
    console = Console(stderr=True)
    cfg = TrainConfig(samples=samples, classifier_epochs=classifier_epochs,
                      regressor_epochs=regressor_epochs, style=style, seed=seed, threads=threads,
                      workers=workers, types=[t.strip() for t in types.split(",") if t.strip()] if types else None,
                      regressors=not classifiers_only,
                      classifier_input=_classifier_input_option(classifier_input),
                      cache=None if no_cache else (cache or DEFAULT_CACHE))
    if console.is_terminal:
        reporter: Any = RichReporter(console)
        with reporter.progress:
            models = train(library, cfg, reporter)
    else:  # a log or a pipe (train_shipped.py): plain lines as the training goes
        models = train(library, cfg, LineReporter())
    save_models(models, output)
    for t, m in models.types.items():
        acc = m.metrics.get("val_accuracy")
        rm = [v for k, v in m.metrics.items() if k.startswith("val_rmse.")]
        rmse = f", regressors' validation RMSE {min(rm):.3f}-{max(rm):.3f}" if rm else ""
        click.echo(f"{t}: {len(m.classes)} classes, validation accuracy {acc:.3f}{rmse}")
    size = output.stat().st_size
    click.echo(f"wrote {output} ({size / 1e6:.2f} MB) in {models.meta['seconds']:.0f} s")


def _classifier_input_option(text: str) -> str | dict[str, str]:
    """`--classifier-input`: KIND, or TYPE=KIND,... (a usage error names a bad KIND)."""
    from .strokes import INPUT_KINDS

    def kind(k: str) -> str:
        if k not in INPUT_KINDS:
            raise click.BadParameter(f"unknown classifier input {k!r}; expected one of "
                                     f"{', '.join(INPUT_KINDS)}", param_hint="--classifier-input")
        return k

    if "=" not in text:
        return kind(text.strip())
    out = {}
    for item in filter(None, (i.strip() for i in text.split(","))):
        t, sep, k = item.partition("=")
        if not sep or not t.strip():
            raise click.BadParameter(f"expected TYPE=KIND, got {item!r}", param_hint="--classifier-input")
        out[t.strip()] = kind(k.strip())
    return out


class LineReporter:
    """Progress as plain lines on stderr (a task's start, then every fifth of it), for logs and
    pipes, where rich's bars would show nothing until the end."""

    def __init__(self) -> None:
        import time

        self._clock = time.monotonic
        self.start = self._clock()

    def say(self, message: str) -> None:
        click.echo(f"[{self._clock() - self.start:7.1f} s] {message}", err=True)

    def task(self, description: str, total: int):  # noqa: ANN201
        self.say(f"{description}: 0 of {total}")
        done = [0]

        def advance(n: int = 1, info: str = "") -> None:
            before = done[0]
            done[0] += n
            step = max(1, total // 5)
            if done[0] >= total or done[0] // step > before // step:
                self.say(f"{description}: {done[0]} of {total} {info}".rstrip())
        return advance

    def note(self, message: str) -> None:
        self.say(f"note: {message}")


class RichReporter:
    """Progress bars for training (rich, on stderr)."""

    def __init__(self, console: Any):
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        self.console = console
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                                 TimeElapsedColumn(), TextColumn("{task.fields[info]}"), console=console)

    def task(self, description: str, total: int):  # noqa: ANN201
        task = self.progress.add_task(description, total=total, info="")

        def advance(n: int = 1, info: str = "") -> None:
            self.progress.update(task, advance=n, info=info)
        return advance

    def note(self, message: str) -> None:
        self.progress.console.print(f"note: {message}")
