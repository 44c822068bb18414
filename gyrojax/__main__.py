"""``python -m gyrojax`` is the ``gyrojax`` command."""

from gyrojax.cli.app import console

console()
