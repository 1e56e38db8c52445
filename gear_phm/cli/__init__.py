"""The ``gear-phm`` command line: one module per subcommand."""
