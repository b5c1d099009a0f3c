"""Benchmarks that put error beside milliseconds, one module each with ``run(args) -> int``
(``genie bench NAME``; their options and the list live in :mod:`genie_gl.commands.bench`).
They print a table and write figures (PNG, JSON) under ``--out``."""
