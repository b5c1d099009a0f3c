"""The ``genie`` subcommands, one module each with ``add_arguments(parser)`` and
``run(args) -> int`` (registered in :data:`genie_gl.cli.COMMANDS`). They sit above every
stage, so a command may use any of them; the stages never import a command."""
