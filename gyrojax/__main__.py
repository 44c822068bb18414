"""``python -m gyrojax`` is the ``gyrojax`` command."""

from .cli import main

raise SystemExit(main())
