"""The ``gyrojax`` command line (:mod:`gyrojax.cli.app`: parser and start-up; :mod:`gyrojax.cli.commands`: what
each sub-command does). The library never imports this package."""

from gyrojax.cli.app import main

__all__ = ["main"]
