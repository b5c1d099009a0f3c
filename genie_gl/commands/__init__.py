"""The ``genie`` subcommands, one module each with ``add_arguments(parser)`` and
``run(args) -> int`` (registered in :data:`genie_gl.cli.COMMANDS`). They sit above every
stage, so a command may use any of them; the stages never import a command."""

from __future__ import annotations

from contextlib import contextmanager

from ..validation.options import count, counts, names, positive, seed, seeds  # noqa: F401  (the commands' option types)


def announce_compilation(command: str) -> None:
    """Say, if this run compiles genie-gl's kernels (numba's cache is cold: the first run), that
    it is a one-time cost (:func:`genie_gl.processes.say_when_compiling`)."""
    from ..processes import say_when_compiling

    say_when_compiling(f"genie {command}")


@contextmanager
def stages(steps: list[str], *, title: str = "genie", enabled: bool = True):
    """A progress bar over a command's stages, naming the one under way: ``with stages([...]) as
    step: step("render"); ...``."""
    from tqdm import tqdm

    # shown on a terminal only (tqdm: disable=None), so a log or a pipe gets the one-line error
    # alone
    bar = tqdm(
        total=len(steps),
        unit="stage",
        disable=True if not enabled else None,
        bar_format="{desc} [{elapsed}]",
    )
    bar.set_description(title)
    seen: list[str] = []

    def step(name: str) -> None:
        if seen:
            bar.update(1)
        seen.append(name)
        bar.set_description(f"{title}: {name} (stage {len(seen)} of {len(steps)})", refresh=True)

    try:
        yield step
        bar.update(len(steps) - bar.n)
    finally:
        bar.close()
