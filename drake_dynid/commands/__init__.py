"""Subcommands of the ``dynid`` command line tool (one module per subcommand)."""
