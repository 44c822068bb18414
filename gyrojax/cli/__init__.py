"""The ``gyrojax`` command line (:mod:`gyrojax.cli.app`: parser and start-up; :mod:`gyrojax.cli.commands`: what
each sub-command does; :mod:`gyrojax.cli.args`: the usage error and the option parsers both share). The library
never imports this package."""

from gyrojax.cli.app import console, main

__all__ = ["console", "main"]
