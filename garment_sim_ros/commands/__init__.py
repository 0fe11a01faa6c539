"""Sub-commands of the ``garment-sim`` command line; one module per command."""
