"""``python -m gyrojax`` is the ``gyrojax`` command."""

from gyrojax.cli.app import main

raise SystemExit(main())
