"""Studies that answer the project's own questions with :func:`genie_gl.eval.evaluate`: which
strategy, sensor, sensor effect or class balance makes data that trains better models. Each
makes the datasets it needs (once, cached) with :func:`genie_gl.dataset.run_dataset`, so it
lives above both ``dataset`` and ``eval``."""
